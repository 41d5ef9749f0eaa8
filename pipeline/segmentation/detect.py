"""Event detection: steps and impulses in a noisy input with a nonzero operating point.

Algorithm (pure function of the record):

1. The input noise ``sigma_u`` is estimated from the median absolute first difference;
   an input change counts when it exceeds ``max(min_step, rel_min_step * range, 5 sigma_u)``.
2. The input is scanned against the current level (the declared ``initial_input`` before
   the first row, else the median of the first samples). A departure from the level starts
   an event at ``t0``; the samples of a ramp or of noise around it belong to the same event.
3. If the input comes back to the level and stays there, and it was away for less than
   ``pulse_fraction`` of the time to the next event, it was a pulse: an impulse event whose
   strength is the area ``A = sum (u - u0) dt`` (zero-order hold). A one-sample spike is a
   pulse too, if it clears twice the threshold (a one- or two-sample blip just over the
   bar is noise on top of a small level shift). Otherwise it is a step to a new level
   (trimmed mean of its plateau). No event without an input change: a step whose levels
   differ by at most half the threshold is the pulse it was when the input came back to
   its level by the plateau's start, else it joins the window before it; so does a pulse
   of next to no area (a doublet). The scan (:mod:`.edges`) is linear in samples and
   events; extreme magnitudes are scaled first (:mod:`.magnitudes`).
4. Each event's window runs to the next event or the end of the record. ``y0`` is the mean
   of the settled output before ``t0``: the whole baseline before the first event, the
   tail of the previous window before a later one, or the first ``head_samples`` (those
   still at the starting level) when the event is at the start of the record. ``y_ss`` is
   the mean over the last ``tail_fraction`` of the window (seed 001 averages the last 11 samples).
5. A step window shorter than ``settle_time_constants`` times the time the output takes to
   reach 63 %, or whose output still drifts (the last tenth's mean differs from the tenth
   before by more than ``settle_drift`` of the change), is flagged ``settled = False``
   (DaISy's 200 s windows are ~3 time constants and its slow second mode still creeps).
6. Integrating responses (the response ``r`` is the output less the baseline line
   ``y0 + drift (t - t0)``). ``drift``: before the first event, the slope of a line fit
   of the baseline, kept when it exceeds 4 standard errors and the baseline lasts at
   least ``drift_span`` (25 %) of the window (a short stretch of a response still
   settling is not extrapolated over a long window; e.g. a motor's angle that already
   turns); before a later event, the previous window's final ramp (0 if it was not a
   ramp). A step window is a ``"ramp"`` when, over its last half, (a) the output's slope
   differs from ``drift`` by more than 5 standard errors, in the direction of ``r``;
   (b) the slope does not fall by more than ``ramp_slope_tol`` (20 %) of that change
   plus 1.5 standard errors (a quadratic fit; a lag's slope falls by 1 - e^{-W/(2T)}
   over the last half of a window W, 53 % at W = 1.5 T); and (c) ``r`` rises at least
   ``ramp_rate`` (95 %) as fast as over the whole window on average,
   ``2 (r_end - r_mid) >= 0.95 r_end`` within 3 standard errors of the means (a
   response whose slope only grows, as a ramp behind a lag, passes; a settling one, whose
   last half adds less than half of its change, does not: 2 e^{-W/(2T)}/(1 + e^{-W/(2T)})
   = 0.64 for a lag at W = 1.5 T). An impulse window is a
   ``"level_shift"`` when its output ends away from the baseline (the "not settled" test
   of step 4 fails) at least at ``level_share`` (80 %) of its largest excursion, with no
   excursion the other way, and is not heading back (over the last half it moves back by
   at most 5 % of the shift, or 4 standard errors). A ramp is ``settled`` (its lag has
   died out: the slope is steady); a level shift is ``settled`` once the level no longer
   moves by more than that either way. For both, ``y0`` is the baseline line at ``t0``.
   Otherwise the response is ``"settling"``. ``slope`` is the output's slope over the
   last half of the window (units per second).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from ..events import Event, EventData
from ..record import Record, make_record
from ..signal import noise_estimate, noise_sigma, smooth
from .edges import Raw, as_pulse, departure, scan
from .magnitudes import Scale, exponent


@dataclass(frozen=True)
class SegmentOptions:
    min_step: float | None = None
    rel_min_step: float = 0.05
    input_noise_factor: float = 5.0
    tail_fraction: float = 0.1
    min_tail_samples: int = 3
    head_samples: int = 2
    pulse_fraction: float = 0.1
    stable_samples: int = 3
    settle_time_constants: float = 4.0
    settle_drift: float = 0.01
    ramp_slope_tol: float = 0.2
    ramp_rate: float = 0.95
    level_share: float = 0.8
    drift_span: float = 0.25


def input_threshold(u: np.ndarray, initial_input: float | None, opt: SegmentOptions
                    ) -> tuple[float, float]:
    """``(threshold, sigma_u)`` for an input change to count as an event."""
    e = exponent(float(np.max(np.abs(u))) if u.size else 0.0)
    if e:  # extreme magnitudes: computed scaled (exactly, by a power of two)
        ii = None if initial_input is None else math.ldexp(initial_input, -e)
        ms = None if opt.min_step is None else math.ldexp(opt.min_step, -e)
        thr, sig = input_threshold(np.ldexp(u, -e), ii, replace(opt, min_step=ms))
        return math.ldexp(thr, e), math.ldexp(sig, e)
    d = np.diff(u)
    sigma_u = _mad_sigma(d) / math.sqrt(2) if d.size else 0
    del d
    # 0.5 / 99.5 percentiles: one huge spike must not raise the bar above the real steps
    lo, hi = (float(v) for v in np.percentile(u, [0.5, 99.5]))
    if initial_input is not None:
        lo, hi = min(lo, initial_input), max(hi, initial_input)
    rel = opt.rel_min_step * (hi - lo)
    floor = opt.min_step if opt.min_step is not None else rel
    # a relative floor only (a signal in femto-units has steps too)
    return max(floor, opt.input_noise_factor * sigma_u,
               1e-12 * max(abs(lo), abs(hi), np.finfo(float).tiny)), sigma_u


def _mad_sigma(d: np.ndarray) -> float:
    """``1.4826 * median(|d - median(d)|)``, the noise scale of the changes ``d`` (an array
    the caller gives up): both medians partition it in place and the deviations overwrite
    it, where each median would copy it (a median does not depend on the order, so it is
    the same number, with no record-long copies)."""
    m = np.median(d, overwrite_input=True)
    np.subtract(d, m, out=d)
    np.abs(d, out=d)
    return float(1.4826 * np.median(d, overwrite_input=True))


def segment(record: Record, options: SegmentOptions | None = None) -> list[Event]:
    """Find the step and impulse events of ``record`` (see the module docstring)."""
    opt = options or SegmentOptions()
    scale = Scale.of(record)
    if scale.needed:  # extreme magnitudes (issue 13 item 15): segment scaled, read back
        if opt.min_step is not None:
            opt = replace(opt, min_step=math.ldexp(opt.min_step, -scale.u))
        return [scale.back(e) for e in segment(scale.record(record), opt)]
    t, u = record.t, record.u
    thr, sigma_u = input_threshold(u, record.initial_input, opt)
    level = (record.initial_input if record.initial_input is not None
             else _starting_level(u, thr))
    raws = scan(t, u, level, thr, sigma_u, stable=opt.stable_samples,
                pulse_fraction=opt.pulse_fraction)
    while True:  # no event without an input change (issue 13 item 14)
        events = _events(record, raws, opt, thr)
        flat = [i for i, e in enumerate(events) if _no_change(e, raws[i], t, thr)]
        if not flat:
            return events
        i = flat[0]
        pulse = as_pulse(u, raws[i], thr, opt.stable_samples) if raws[i].kind == "step" else None
        raws = raws[:i] + ([pulse] if pulse else []) + raws[i + 1 :]


def _no_change(e: Event, r: Raw, t: np.ndarray, thr: float) -> bool:
    """A step whose refined levels differ by no more than half the threshold (the scan's
    raw levels differ by more than all of it), or a pulse whose
    area is under half the threshold's over one of its sample intervals (a doublet):
    no input change a method could divide by. Such a step is the pulse it was when the
    input came back (:func:`.edges.as_pulse`); else, and such a pulse, it joins the window
    before it."""
    if e.kind == "step":
        return abs(e.u_ss - e.u0) <= 0.5 * thr
    return abs(e.area) < 0.5 * thr * float(t[r.j] - t[r.k]) / max(1, r.j - r.k)


def _starting_level(u: np.ndarray, thr: float, m: int = 5) -> float:
    """Median of the first samples before the input first moves by more than ``thr``
    (a step at the second sample must not become the starting level)."""
    first = departure(u, 0, float(u[0]), thr)
    return float(np.median(u[: max(1, min(m, first))]))


def _events(record: Record, raws: list[Raw], opt: SegmentOptions, thr: float) -> list[Event]:
    t, u, y = record.t, record.u, record.y
    n = u.size
    events: list[Event] = []
    prev_ramp = (0.0, 0.0)
    last_step: float | None = None  # the refined level of the last step's plateau
    for idx, r in enumerate(raws):
        end = raws[idx + 1].k if idx + 1 < len(raws) else n
        prev = raws[idx - 1].k if idx > 0 else 0
        # baseline before t0
        if r.k == 0:
            i_base, base = 0, _head(y[: max(1, min(opt.head_samples, end))],
                                    noise_sigma(y[:end]))
        else:
            # before the first event the record sits at its operating point: all of it
            # is settled baseline; later, only the tail of the previous window is
            m = max(opt.min_tail_samples, int(opt.tail_fraction * (r.k - prev)))
            i_base = 0 if idx == 0 else max(prev, r.k - m)
            base = y[i_base : r.k]
        y0 = float(np.mean(base))
        m = max(opt.min_tail_samples, int(opt.tail_fraction * (end - r.k)))
        y_ss = float(np.mean(y[max(r.k, end - m) : end]))
        est = noise_estimate(y[i_base:end])
        noise = est.sigma
        # means and slopes over many samples: coloured noise averages out more slowly
        # (variance x correlation_samples), so their tests use the inflated sigma
        noise_avg = noise * math.sqrt(est.correlation_samples)
        if r.kind == "step":
            plateau = u[r.j : end]
            if plateau.size:
                plateau = plateau[np.abs(plateau - np.median(plateau)) <= thr]
            u_ss = _trim_mean(plateau, 0.1) if plateau.size else float(u[r.j])
            u0 = r.level_before if last_step is None else last_step
            area, dur = 0.0, 0.0
            settled = _step_settled(t[r.k : end], y[r.k : end], y0, y_ss, noise_avg, opt)
        else:
            u0 = u_ss = r.level_before if last_step is None else last_step
            dt = np.diff(t[r.k : r.j + 1])
            area = float(np.sum((u[r.k : r.j] - u0) * dt))
            dur = float(t[r.j] - t[r.k])
            peak = float(np.max(np.abs(y[r.k : end] - y0))) if end > r.k else 0.0
            settled = abs(y_ss - y0) <= 0.05 * peak + 3 * noise
        if idx == 0:
            drift, e_drift = _drift(t[i_base : r.k], y[i_base : r.k], noise_avg,
                                    opt.drift_span * (t[end - 1] - t[r.k]))
        else:  # the previous window's final ramp goes on (0 if it settled or shifted)
            drift, e_drift = prev_ramp
        y_line = y0 + drift * (t[r.k] - float(np.mean(t[i_base : r.k]))) if drift else y0
        w = _window(t[r.k : end], y[r.k : end], y_line, drift, e_drift, noise_avg)
        response = "settling"
        if w is not None and r.kind == "step" and _is_ramp(w, opt):
            response, settled = "ramp", True
        elif w is not None and r.kind == "impulse" and not settled:
            shifted, still = _level_shift(w, opt)
            response, settled = ("level_shift", still) if shifted else ("settling", False)
        if response != "settling":
            y0 = y_line
        prev_ramp = (w.slope, w.e_slope) if response == "ramp" else (0.0, 0.0)
        events.append(Event(
            index=idx, kind=r.kind, i_start=r.k, i_end=end, i_base=i_base, t0=float(t[r.k]),
            t_end=float(t[end - 1]), u0=float(u0), u_ss=float(u_ss), y0=float(y0),
            y_ss=y_ss, area=area, duration=dur, settled=bool(settled), noise=noise,
            response=response, slope=w.slope if w is not None else 0.0, drift=drift,
            tail=_tail(events[-1]) if events else 0.0,
        ))
        if r.kind == "step":
            last_step = float(u_ss)
    return events


def _trim_mean(a: np.ndarray, cut: float) -> float:
    """``scipy.stats.trim_mean(a, cut)`` of a 1-D array, computed as it does (the same
    partition and mean, hence the same bits) without its per-call overhead (4 ms, most of
    an event's cost on a short window)."""
    lo = int(cut * a.size)
    return float(np.mean(np.partition(a, (lo, a.size - lo - 1))[lo : a.size - lo]))


def _tail(prev: Event) -> float:
    """The previous event's change when its response was still settling at its end."""
    return 0.0 if prev.settled or prev.response != "settling" else prev.y_ss - prev.y0


def _line(t: np.ndarray, y: np.ndarray, sigma: float) -> tuple[float, float]:
    """Least-squares slope of ``y`` over ``t`` and its standard error for white noise
    ``sigma``."""
    tc = t - np.mean(t)
    sxx = float(np.dot(tc, tc))
    if t.size < 2 or sxx <= 0:
        return 0.0, math.inf
    return float(np.dot(tc, y - np.mean(y)) / sxx), sigma / math.sqrt(sxx)


def _drift(t: np.ndarray, y: np.ndarray, sigma: float, min_span: float,
           min_samples: int = 10) -> tuple[float, float]:
    """``(slope, standard error)`` of the baseline before the first event: 0 unless it
    is significant and the baseline lasts ``min_span`` (a short stretch of a response
    still settling must not be extrapolated over a long window)."""
    if t.size < min_samples or t[-1] - t[0] < min_span:
        return 0.0, 0.0
    slope, se = _line(t, y, sigma)
    return (slope, se) if abs(slope) > 4 * se else (0.0, 0.0)


@dataclass(frozen=True)
class _Window:
    """The readings of step 6 on one event window: the response ``r`` (output less the
    baseline line extrapolated from t0), its mean over the last tenth, and the output's
    slope over the last half with its standard error."""

    t: np.ndarray
    r: np.ndarray
    r_end: float
    slope: float
    e_slope: float
    drift: float
    e_drift: float
    noise: float

    @property
    def span(self) -> float:
        """Duration of the last half."""
        return float(self.t[-1] - self.t[self.t.size // 2])


def _window(t, y, y0, drift, e_drift, noise) -> _Window | None:
    """Step 6 readings, or None for a window too short to tell (fewer than 40 samples)."""
    if t.size < 40:
        return None
    h, m = t.size // 2, max(3, t.size // 10)
    r = y - y0 - drift * (t - t[0])
    slope, e_slope = _line(t[h:], y[h:], noise)
    return _Window(t, r, float(np.mean(r[-m:])), slope, e_slope, drift, e_drift, noise)


def _is_ramp(w: _Window, opt: SegmentOptions) -> bool:
    """Step 6 (a)-(c) for a step window."""
    n = w.t.size
    h, m = n // 2, max(3, n // 10)
    d = w.slope - w.drift
    sign = math.copysign(1.0, w.r_end)
    changed = d * sign > 5 * math.hypot(w.e_slope, w.e_drift)
    # (b) the slope does not fall over the last half: r = c0 + c1 x + c2 x^2 there
    x = w.t[h:] - 0.5 * (w.t[h] + w.t[-1])
    X = np.stack([np.ones_like(x), x, x * x], axis=1)
    c, *_ = np.linalg.lstsq(X, w.r[h:], rcond=None)
    e_c2 = w.noise * math.sqrt(float(np.linalg.inv(X.T @ X)[2, 2]))
    fall = -2.0 * c[2] * w.span * sign  # slope lost across the last half
    steady = fall <= opt.ramp_slope_tol * abs(d) + 1.5 * 2.0 * e_c2 * w.span
    # (c) the last half rises at least ramp_rate as fast as the whole window on average
    r_mid = float(np.mean(w.r[max(0, h - m // 2) : h - m // 2 + m]))
    lead = sign * (2.0 * (w.r_end - r_mid) - opt.ramp_rate * w.r_end)
    e_lead = w.noise * math.sqrt(((2.0 - opt.ramp_rate) ** 2 + 4.0) / m)
    return changed and steady and lead >= -3 * e_lead


def _level_shift(w: _Window, opt: SegmentOptions) -> tuple[bool, bool]:
    """``(is a level shift, settled)`` for an impulse window that is not back at its
    baseline (step 6)."""
    if w.r_end == 0:
        return False, False
    rs = smooth(w.r, w.noise / max(float(np.max(np.abs(w.r))), 1e-300))
    sign = math.copysign(1.0, w.r_end)
    reach, other = float(np.max(sign * rs)), float(np.max(-sign * rs))
    moving = sign * (w.slope - w.drift) * w.span  # away from the baseline
    still = max(0.05 * abs(w.r_end), 4 * math.hypot(w.e_slope, w.e_drift) * w.span)
    stays = abs(w.r_end) >= opt.level_share * reach and moving >= -still
    one_way = other <= 0.2 * abs(w.r_end) + 3 * w.noise
    return stays and one_way, stays and one_way and moving <= still


def _head(y: np.ndarray, sigma: float) -> np.ndarray:
    """The first samples of a record that still sit at the starting level (within 3 sigma):
    at the start of a record the response may already be moving at the second sample."""
    keep = np.abs(y - y[0]) <= 3 * sigma + 1e-12 * max(1.0, abs(y[0]))
    n = int(np.argmin(keep)) if not keep.all() else y.size
    return y[: max(1, n)]


def _step_settled(t, y, y0, y_ss, noise, opt: SegmentOptions) -> bool:
    """Long enough (``settle_time_constants`` x the 63 % time) and no longer drifting: the
    mean of the last tenth of the window differs from the tenth before it by at most
    ``settle_drift`` of the change (or the noise of those means)."""
    dy = y_ss - y0
    if t.size < 20 or dy == 0:
        return False
    m = t.size // 10
    drift = abs(float(np.mean(y[-m:]) - np.mean(y[-2 * m : -m])))
    if drift > max(opt.settle_drift * abs(dy), 4 * noise / math.sqrt(m)):
        return False
    h = smooth((y - y0) / dy, noise / abs(dy))
    reach = np.flatnonzero(h >= 0.632)
    if reach.size == 0:
        return False
    t63 = t[reach[0]] - t[0]
    return bool(t[-1] - t[0] >= opt.settle_time_constants * max(t63, t[1] - t[0]))


def event_data(t, u, y, *, initial_input: float | None = None, event: int = 0,
               options: SegmentOptions | None = None, **override) -> EventData:
    """Segment plain arrays and return the :class:`EventData` of event number ``event``;
    keywords override any field (e.g. ``y0=...``, ``kind="impulse"``, ``area=...``).

    The way to run a method on numpy arrays without a file or the CLI::

        fit = identify(event_data(t, u, y), "first_order")
    """
    rec = make_record(t, u, y, name="arrays", source="<arrays>", initial_input=initial_input)
    events = segment(rec, options)
    if not events:
        raise ValueError("no step or impulse event found in the arrays")
    if not -len(events) <= event < len(events):
        raise ValueError(f"event {event} does not exist: {len(events)} event(s) were found "
                         f"(0..{len(events) - 1})")
    return replace(EventData.from_event(rec, events[event]), **override)
