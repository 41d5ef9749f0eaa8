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
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
from scipy.stats import trim_mean

from .events import Event, EventData
from .record import Record, make_record
from .signal import noise_sigma, smooth


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
        noise = noise_sigma(y[i_base:end])
        if r.kind == "step":
            plateau = u[r.j : end]
            if plateau.size:
                plateau = plateau[np.abs(plateau - np.median(plateau)) <= thr]
            u_ss = float(trim_mean(plateau, 0.1)) if plateau.size else float(u[r.j])
            u0 = r.level_before if idx == 0 else _level_before(events, r)
            area, dur = 0.0, 0.0
            settled = _step_settled(t[r.k : end], y[r.k : end], y0, y_ss, noise, opt)
        else:
            u0 = u_ss = r.level_before if idx == 0 else _level_before(events, r)
            dt = np.diff(t[r.k : r.j + 1])
            area = float(np.sum((u[r.k : r.j] - u0) * dt))
            dur = float(t[r.j] - t[r.k])
            peak = float(np.max(np.abs(y[r.k : end] - y0))) if end > r.k else 0.0
            settled = abs(y_ss - y0) <= 0.05 * peak + 3 * noise
        events.append(Event(
            index=idx, kind=r.kind, i_start=r.k, i_end=end, i_base=i_base, t0=float(t[r.k]),
            t_end=float(t[end - 1]), u0=float(u0), u_ss=float(u_ss), y0=y0, y_ss=y_ss,
            area=area, duration=dur, settled=bool(settled), noise=noise,
        ))
    return events


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
    return replace(EventData.from_event(rec, events[event]), **override)
