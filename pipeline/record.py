"""``Record``: one experiment, the common currency of every loader (DESIGN.md)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .errors import UserError


@dataclass(frozen=True)
class Record:
    """One logged experiment.

    ``t`` is strictly increasing (seconds), ``u`` and ``y`` are the input and output,
    all float64 1-D arrays of equal length, read-only (copies of the caller's arrays, or a
    loader's own arrays made read-only, see :func:`make_record`).
    ``sample_time`` is ``None`` when the grid is irregular. ``units["time"]`` is the unit
    the user reads times in (``t`` is seconds whatever it says; :func:`in_time_unit`
    converts); ``start`` is the absolute time of ``t[0]`` (ISO-8601 with its offset) when
    the log has date-times. ``initial_input`` is the input level declared to hold *before*
    the first row (e.g. DaISy's 6.0 V): when it differs from ``u[0]`` a step happens at
    ``t[0]`` that is invisible in the input column.
    """

    t: np.ndarray
    u: np.ndarray
    y: np.ndarray
    name: str
    source: str
    units: dict[str, str] = field(default_factory=dict)
    sample_time: float | None = None
    initial_input: float | None = None
    input_name: str = "u"
    output_name: str = "y"
    notes: tuple[str, ...] = ()  # warnings from loading (gaps, unindexed scan, ...)
    start: str | None = None  # the absolute time of t[0], ISO-8601 with offset, when known
    #: output samples taken as single-sample outliers and replaced for the analysis:
    #: ``(row, value read, value used)`` (:func:`pipeline.outliers.without_outliers`)
    outliers: tuple[tuple[int, float, float], ...] = ()
    #: the setpoint of a closed loop whose controller output is the input (``data.setpoint``,
    #: :func:`with_setpoint`): read-only, as long as ``t``; None for an open-loop test
    r: np.ndarray | None = None
    setpoint_name: str | None = None

    @property
    def n_samples(self) -> int:
        return int(self.t.size)

    def sampling(self) -> tuple[float | None, float | None]:
        """``(median interval, jitter)`` of the time stamps, in seconds and as the
        intervals' standard deviation over their median: ``(sample_time, 0)`` on a
        uniform grid; what an irregular grid (a logger's clock) has instead of a sample
        time (results.json ``median_interval``, ``interval_jitter``)."""
        if self.sample_time is not None:
            return self.sample_time, 0.0
        if self.t.size < 2:
            return None, None
        dt = np.diff(self.t)
        med = float(np.median(dt))
        return med, (float(np.std(dt)) / med if med > 0 else None)


#: The time units a log may be in: name -> (numerator, denominator) of one unit in seconds,
#: so that ms -> s divides by 1000 (exactly rounded) instead of multiplying by 0.001.
TIME_UNITS: dict[str, tuple[int, int]] = {"s": (1, 1), "ms": (1, 1000), "min": (60, 1),
                                          "h": (3600, 1)}

#: Other spellings of the time units (headers such as ``Zeit [sec]``).
TIME_UNIT_ALIASES: dict[str, str] = {
    "sec": "s", "second": "s", "seconds": "s", "msec": "ms", "millisecond": "ms",
    "milliseconds": "ms", "minute": "min", "minutes": "min", "hr": "h", "hour": "h",
    "hours": "h",
}


def time_unit(text: str) -> str | None:
    """The time unit a text names (``"ms"``, ``"sec"``, ``"Hours"``), or None."""
    key = text.strip().lower()
    return key if key in TIME_UNITS else TIME_UNIT_ALIASES.get(key)


def to_seconds(values, unit: str):
    """Times in ``unit`` (a name of :data:`TIME_UNITS`) as seconds."""
    num, den = TIME_UNITS[unit]
    if num == den == 1:
        return values  # seconds already: no copy of a long record's time
    return values * num / den if num != 1 else values / den


def in_time_unit(seconds, unit: str | None):
    """Seconds shown in the user's time unit (``record.units.get("time")``; None or an
    unknown name: seconds), e.g. a time constant of 450 s as 7.5 min."""
    if unit is None or time_unit(unit) is None:
        return seconds
    num, den = TIME_UNITS[time_unit(unit)]
    return seconds * den / num if den != 1 else seconds / num


#: A time step this many times the median interval is a broken log, not a sample.
MAX_GAP_FACTOR = 1000.0


#: A record's grid is uniform (it has a ``sample_time``) when every interval is within
#: this share of the mean interval (the simulator allows more,
#: :data:`pipeline.simulation.engine.UNIFORM_REL_TOL`).
SAMPLE_TIME_REL_TOL = 1e-6


def uniform_step(t: np.ndarray, rel_tol: float = SAMPLE_TIME_REL_TOL,
                 intervals: np.ndarray | None = None) -> float | None:
    """The sample time of ``t`` when its grid is uniform, else None: the one rule of the
    package. Uniform means every interval is within ``rel_tol`` of the mean interval
    ``(t[-1] - t[0]) / (n - 1)`` (the mean, not the median: no sort; on a uniform grid
    the two agree to rounding). ``intervals``: ``np.diff(t)`` when the caller has them."""
    t = np.asarray(t, dtype=np.float64)
    if t.size < 2:
        return None
    d = np.diff(t) if intervals is None else intervals
    mean = float(t[-1] - t[0]) / (t.size - 1)
    tol = rel_tol * mean + 1e-12
    if mean > 0 and float(d.max()) - mean <= tol and mean - float(d.min()) <= tol:
        return mean
    return None


#: Values beyond this magnitude overflow a fit's squared errors (1e150 squared is 1e300,
#: near float64's largest, 1.8e308), so a record refuses them: the signal is to be scaled.
LARGEST_VALUE = 1e150
#: An input or output no larger than this anywhere (but not all zero) underflows them
#: (1e-150 squared is 1e-300, near float64's smallest normal, 2.2e-308): refused too.
SMALLEST_VALUE = 1e-150


def make_record(
    t, u, y, *, name: str, source: str, units: dict[str, str] | None = None,
    initial_input: float | None = None, input_name: str = "u", output_name: str = "y",
    notes: tuple[str, ...] = (), start: str | None = None, copy: bool = True,
    intervals: np.ndarray | None = None,
) -> Record:
    """Validate arrays and build a :class:`Record`; a problem is a :class:`UserError`.

    The record holds read-only copies of ``t, u, y``; with ``copy=False`` (a loader whose
    arrays nobody else holds) it holds them as they are, made read-only: a long log is then
    never copied. ``intervals`` are ``np.diff(t)`` when the caller has them
    (they are reordered here: the caller gives them away).
    """
    t, u, y = (np.array(a, dtype=np.float64, copy=True) if copy else
               np.asarray(a, dtype=np.float64) for a in (t, u, y))
    if not (t.ndim == u.ndim == y.ndim == 1) or not (t.size == u.size == y.size):
        raise UserError(f"{source}: t, u and y must be 1-D arrays of equal length")
    if t.size < 10:
        raise UserError(f"{source}: {t.size} samples; at least 10 are needed")
    for label, a in (("time", t), (input_name, u), (output_name, y)):
        _check_values(a, label, source, signal=a is not t)
    if initial_input is not None and not np.isfinite(initial_input):
        raise UserError(f"{source}: initial_input is {initial_input}; expected a number")
    dt = np.diff(t) if intervals is None or intervals.size != t.size - 1 else intervals
    if dt.min() <= 0:
        k = int(np.flatnonzero(dt <= 0)[0])
        raise UserError(
            f"{source}: time is not strictly increasing at data row {k + 2} "
            f"({t[k]} then {t[k + 1]}); expected increasing time stamps"
        )
    k = int(np.argmax(dt))
    jump = float(dt[k])
    sample_time = uniform_step(t, intervals=dt)
    med = sample_time or float(np.median(dt, overwrite_input=True))  # dt reordered
    if jump > MAX_GAP_FACTOR * med:
        raise UserError(
            f"{source}: time jumps by {jump:.6g} s at data row {k + 2} while the median "
            f"interval is {med:.6g} s; split the log there or remove the gap"
        )
    for a in (t, u, y):
        a.setflags(write=False)  # methods get views of these; nothing may change them
    return Record(
        t=t, u=u, y=y, name=name, source=source, units=dict(units or {}),
        sample_time=sample_time, initial_input=initial_input,
        input_name=input_name, output_name=output_name, notes=tuple(notes), start=start,
    )


def _check_values(a: np.ndarray, label: str, source: str, signal: bool = True) -> None:
    """Every value finite and small enough for a fit's squared errors (LARGEST_VALUE); a
    ``signal`` (not the time) also not so tiny that they underflow (SMALLEST_VALUE)."""
    lo, hi = a.min(), a.max()
    if -LARGEST_VALUE <= lo and hi <= LARGEST_VALUE:  # two passes, no temporaries (NaN
        peak = max(-lo, hi)  # fails both comparisons)
        if signal and 0 < peak < SMALLEST_VALUE:
            raise UserError(
                f"{source}: column '{label}' is at most {peak:.3g} in magnitude; values below "
                f"{SMALLEST_VALUE:.0e} underflow the squared errors of a fit: scale the "
                "signal (e.g. a unit with a smaller prefix)")
        return
    finite = np.isfinite(a)
    if not finite.all():
        raise UserError(
            f"{source}: column '{label}' has a missing or non-numeric value at data row "
            f"{int(np.argmin(finite)) + 1}; expected a finite number"
        )
    del finite
    big = np.abs(a) > LARGEST_VALUE
    if big.any():
        k = int(np.argmax(big))
        raise UserError(
            f"{source}: column '{label}' has {a[k]:.6g} at data row {k + 1}; values beyond "
            f"{LARGEST_VALUE:.0e} overflow the squared errors of a fit: scale the signal "
            "(e.g. a unit with a larger prefix)"
        )


def with_setpoint(record: Record, r, name: str) -> Record:
    """``record`` with the setpoint ``r`` (a closed loop's, sampled at ``record.t``) named
    ``name``: checked as the input and output are (:func:`make_record`), held read-only."""
    from dataclasses import replace

    r = np.array(r, dtype=np.float64, copy=True)
    if r.shape != record.t.shape:
        raise UserError(f"{record.source}: the setpoint '{name}' has {r.size} samples and "
                        f"the log {record.t.size}; expected one per time stamp")
    _check_values(r, name, record.source)
    r.setflags(write=False)
    return replace(record, r=r, setpoint_name=name)
