"""``Record``: one experiment, the common currency of every loader (DESIGN.md)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .errors import UserError


@dataclass(frozen=True)
class Record:
    """One logged experiment.

    ``t`` is strictly increasing (seconds), ``u`` and ``y`` are the input and output,
    all float64 1-D arrays of equal length, read-only (the record owns copies).
    ``sample_time`` is ``None`` when the grid is irregular. ``initial_input`` is the
    input level declared to hold *before* the first row (e.g. DaISy's 6.0 V): when it
    differs from ``u[0]`` a step happens at ``t[0]`` that is invisible in the input column.
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

    @property
    def n_samples(self) -> int:
        return int(self.t.size)


#: A time step this many times the median interval is a broken log, not a sample.
MAX_GAP_FACTOR = 1000.0


def infer_sample_time(t: np.ndarray, rel_tol: float = 1e-6) -> float | None:
    """The constant sample time of ``t``, or ``None`` when the grid is irregular."""
    if t.size < 2:
        return None
    dt = np.diff(t)
    med = float(np.median(dt))
    if med > 0 and np.max(np.abs(dt - med)) <= rel_tol * max(med, 1e-300) + 1e-12:
        return med
    return None


def make_record(
    t, u, y, *, name: str, source: str, units: dict[str, str] | None = None,
    initial_input: float | None = None, input_name: str = "u", output_name: str = "y",
    notes: tuple[str, ...] = (),
) -> Record:
    """Validate arrays and build a :class:`Record`; a problem is a :class:`UserError`."""
    t, u, y = (np.array(a, dtype=np.float64, copy=True) for a in (t, u, y))
    if not (t.ndim == u.ndim == y.ndim == 1) or not (t.size == u.size == y.size):
        raise UserError(f"{source}: t, u and y must be 1-D arrays of equal length")
    if t.size < 10:
        raise UserError(f"{source}: {t.size} samples; at least 10 are needed")
    for label, a in (("time", t), (input_name, u), (output_name, y)):
        bad = np.flatnonzero(~np.isfinite(a))
        if bad.size:
            raise UserError(
                f"{source}: column '{label}' has a missing or non-numeric value at data row "
                f"{int(bad[0]) + 1}; expected a finite number"
            )
    if initial_input is not None and not np.isfinite(initial_input):
        raise UserError(f"{source}: initial_input is {initial_input}; expected a number")
    dt = np.diff(t)
    if np.any(dt <= 0):
        k = int(np.flatnonzero(dt <= 0)[0])
        raise UserError(
            f"{source}: time is not strictly increasing at data row {k + 2} "
            f"({t[k]} then {t[k + 1]}); expected increasing time stamps"
        )
    med = float(np.median(dt))
    if np.max(dt) > MAX_GAP_FACTOR * med:
        k = int(np.argmax(dt))
        raise UserError(
            f"{source}: time jumps by {dt[k]:.6g} s at data row {k + 2} while the median "
            f"interval is {med:.6g} s; split the log there or remove the gap"
        )
    for a in (t, u, y):
        a.setflags(write=False)  # methods get views of these; nothing may change them
    return Record(
        t=t, u=u, y=y, name=name, source=source, units=dict(units or {}),
        sample_time=infer_sample_time(t), initial_input=initial_input,
        input_name=input_name, output_name=output_name, notes=tuple(notes),
    )
