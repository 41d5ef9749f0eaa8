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
   (trimmed mean of its plateau).
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
from scipy.stats import trim_mean

from .events import Event, EventData
from .record import Record, make_record
from .signal import noise_estimate, noise_sigma, smooth


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


@dataclass(frozen=True)
class _Raw:
    kind: str
    k: int  # first sample off the old level
    j: int  # first sample of the new plateau (step) / back on the baseline (impulse)
    level_before: float


def input_threshold(u: np.ndarray, initial_input: float | None, opt: SegmentOptions
                    ) -> tuple[float, float]:
    """``(threshold, sigma_u)`` for an input change to count as an event."""
    d = np.diff(u)
    sigma_u = float(1.4826 * np.median(np.abs(d - np.median(d))) / math.sqrt(2)) if d.size else 0
    # 0.5 / 99.5 percentiles: one huge spike must not raise the bar above the real steps
    lo, hi = (float(v) for v in np.percentile(u, [0.5, 99.5]))
    if initial_input is not None:
        lo, hi = min(lo, initial_input), max(hi, initial_input)
    rel = opt.rel_min_step * (hi - lo)
    floor = opt.min_step if opt.min_step is not None else rel
    return max(floor, opt.input_noise_factor * sigma_u, 1e-12 * max(1.0, abs(hi))), sigma_u


def segment(record: Record, options: SegmentOptions | None = None) -> list[Event]:
    """Find the step and impulse events of ``record`` (see the module docstring)."""
    opt = options or SegmentOptions()
    t, u, _y = record.t, record.u, record.y
    n = u.size
    thr, sigma_u = input_threshold(u, record.initial_input, opt)
    level = (record.initial_input if record.initial_input is not None
             else _starting_level(u, thr))
    raws: list[_Raw] = []
    k = 0
    while k < n:
        if abs(u[k] - level) <= thr:
            k += 1
            continue
        back = _first_stable(u, k + 1, level, thr, opt.stable_samples)
        if back is not None:
            nxt = _next_departure(u, back, level, thr)
            t_next = t[nxt] if nxt < n else t[-1] + (t[-1] - t[-2])
            if t[back] - t[k] < opt.pulse_fraction * (t_next - t[k]):
                if back - k <= 2 and np.max(np.abs(u[k:back] - level)) < 2 * thr:
                    k = back  # a one- or two-sample blip barely over the bar: noise
                    continue
                raws.append(_Raw("impulse", _walk_back(u, k, level, sigma_u), back, level))
                k = back
                continue
        j = _plateau_start(u, k, thr, opt.stable_samples, sigma_u)
        raws.append(_Raw("step", _walk_back(u, k, level, sigma_u), j, level))
        level = float(np.median(u[j : j + opt.stable_samples]))
        k = j
    return _events(record, raws, opt, thr)


def _starting_level(u: np.ndarray, thr: float, m: int = 5) -> float:
    """Median of the first samples before the input first moves by more than ``thr``
    (a step at the second sample must not become the starting level)."""
    moved = np.flatnonzero(np.abs(u - u[0]) > thr)
    first = int(moved[0]) if moved.size else u.size
    return float(np.median(u[: max(1, min(m, first))]))


def _first_stable(u, start, level, thr, m) -> int | None:
    """First index >= start from which ``m`` samples (or the rest) sit within thr of level."""
    near = np.abs(u[start:] - level) <= thr
    idx = np.flatnonzero(near)
    for i in idx:
        run = near[i : i + m]
        if run.all():
            return start + int(i)
    return None


def _next_departure(u, start, level, thr) -> int:
    off = np.flatnonzero(np.abs(u[start:] - level) > thr)
    return start + int(off[0]) if off.size else u.size


def _plateau_start(u, k, thr, m, sigma_u: float = 0.0, m_flat: int = 10) -> int:
    """First index j >= k where the input has stopped moving: the next ``m`` samples agree
    within thr/2, and the means of the two halves of the next ``2 m_flat`` samples differ
    by no more than their noise (3 sigma) or thr/20: a slow ramp changes a little per
    sample, even under noise, but keeps moving."""
    n = u.size
    flat = max(3.0 * sigma_u * np.sqrt(2.0 / m_flat), thr / 20)
    for j in range(k, n):
        w = u[j : j + m]
        if not np.all(np.abs(w - np.median(w)) <= thr / 2):
            continue
        v = u[j : j + 2 * m_flat]
        half = v.size // 2
        if half < m or abs(float(np.mean(v[:half]) - np.mean(v[half:]))) <= flat:
            return j
    return k


def _walk_back(u, k, level, sigma_u) -> int:
    """Move a departure back to where a slow ramp really began (noise-aware)."""
    tol = max(3 * sigma_u, 1e-9 * max(1.0, abs(level)))
    while k > 0 and abs(u[k - 1] - level) > tol and abs(u[k - 1] - level) < abs(u[k] - level):
        k -= 1
    return k


def _events(record: Record, raws: list[_Raw], opt: SegmentOptions, thr: float) -> list[Event]:
    t, u, y = record.t, record.u, record.y
    n = u.size
    events: list[Event] = []
    prev_ramp = (0.0, 0.0)
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
            u_ss = float(trim_mean(plateau, 0.1)) if plateau.size else float(u[r.j])
            u0 = r.level_before if idx == 0 else _level_before(events, r)
            area, dur = 0.0, 0.0
            settled = _step_settled(t[r.k : end], y[r.k : end], y0, y_ss, noise_avg, opt)
        else:
            u0 = u_ss = r.level_before if idx == 0 else _level_before(events, r)
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
    return events


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


def _level_before(events: list[Event], r: _Raw) -> float:
    """The refined level of the previous step's plateau (its trimmed mean)."""
    for ev in reversed(events):
        if ev.kind == "step":
            return ev.u_ss
    return r.level_before


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
