"""Event-level readings shared by the methods: the normalised response and the dead time.

The array-level toolbox (noise, smoothing, crossings, extrema) is :mod:`pipeline.signal`;
here it is applied to an :class:`~pipeline.events.EventData`:

* :func:`input_change` - the step's input change ``du``; not applicable when the input
  did not change (``du`` zero, not finite or within the input's noise);
* :func:`normalised` - time since t0, fractional response and its noise level, for the
  self-regulating methods (not applicable to a ramp or an inverse response), as a
  :class:`~pipeline.methods.prepared.Response`: smoothed and differentiated once per event;
* :func:`undershoot` - the wrong-way excursion of an inverse response;
* :func:`band_exit_time` - seed 001 "Time delay": when the output leaves its noise band
  (ERRATA [S1] 14: the first exit of a +-max(1 %, 4 sigma) band);
* :func:`clip_delay` - a negative computed delay becomes 0, recorded as ``delay_computed``
  and ``delay_clipped`` in every method's diagnostics.

Every reading here is computed once per event (:func:`pipeline.methods.prepared.per_event`) and
shared by the methods that need it: the same response object, the same smoothing.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.ndimage import uniform_filter1d

from ..errors import NotApplicable
from ..events import EventData
from ..signal import NOISE_FREE, interp_cross
from .prepared import Response, per_event

#: An input change within this many of the input's noise standard deviations is none.
INPUT_NOISE_Z = 3.0


@per_event
def input_change(ev: EventData) -> float:
    """``du = u_ss - u0`` of a step; :class:`NotApplicable` when the input did not change:
    ``du`` zero or not finite, or within ``INPUT_NOISE_Z`` standard deviations of the
    input's noise (read as segmentation reads it, from the median absolute first
    difference, ``MAD / (0.6745 sqrt 2)``). Every gain ``dy/du`` of a step method is
    behind this test, so an event whose input did not move gives no division by zero."""
    du = ev.u_ss - ev.u0
    if du == 0 or not math.isfinite(du):
        raise NotApplicable(f"the input did not change (u_ss - u0 = {du:.3g}): no step to "
                            "read a response to")
    d = np.diff(ev.u)
    sigma_u = float(np.median(np.abs(d))) / (0.6745 * math.sqrt(2.0)) if d.size else 0.0
    if abs(du) <= INPUT_NOISE_Z * sigma_u:
        raise NotApplicable(f"the input change ({du:.3g}) is within the input's noise "
                            f"(+-{INPUT_NOISE_Z:g} x {sigma_u:.3g}): no step to read a "
                            "response to")
    return du


@per_event
def fraction(ev: EventData) -> Response:
    """The fractional response (y - y0)/(y_ss - y0) against the time since t0, with its
    noise level (a :class:`~pipeline.methods.prepared.Response`, unpacking as ``tau, h,
    sigma_h``); a step whose input or output did not change is not applicable."""
    if ev.kind == "step":
        input_change(ev)
    if ev.dy == 0 or not np.isfinite(ev.dy) or abs(ev.dy) <= 3 * ev.noise:
        raise NotApplicable(ev.unchanged_reason())
    tau, dy = ev.after()
    return Response(tau, dy / ev.dy, ev.noise / abs(ev.dy))


@per_event
def normalised(ev: EventData) -> Response:
    """:func:`fraction` for the self-regulating methods (chains of lags, second order):
    not applicable to a ramp (an integrating response has no steady-state gain) or to an
    inverse response (no chain of lags moves the wrong way first; :func:`undershoot`)."""
    if ev.response == "ramp":
        raise NotApplicable("the output ramps without settling (an integrating process): "
                            "a self-regulating model has no gain for it")
    r = fraction(ev)
    refuse_moving_start(ev)
    u = undershoot(ev)
    if u is not None:
        raise NotApplicable(f"the output first moves the wrong way, by {u['depth']:.1%} of "
                            f"its change at {u['t']:.3g} s after the step (an inverse "
                            "response): no chain of lags undershoots")
    return r


#: An undershoot counts when it is deeper than this fraction of the change (and the noise).
UNDERSHOOT_MIN = 0.02


@per_event
def moving_the_other_way(ev: EventData) -> str | None:
    """Why the output was still heading against the step's change at t0, or None.

    A step that comes while the previous response still settles the other way
    (``ev.tail``), or on a baseline whose slope heads the other way beyond 4 standard
    errors of a line through it and by more than UNDERSHOOT_MIN of the change over the
    stretch, makes the output go on the wrong way for a while:
    momentum, not a zero. A reading from rest (every graphical method) cannot tell the two
    apart."""
    if ev.dy == 0:
        return None
    if ev.tail * ev.dy < 0:
        return f"the previous response (a change of {ev.tail:.3g}) had not settled"
    i0 = ev.i0
    if i0 < 5:
        return None
    t, y = ev.t[:i0], ev.y[:i0]
    tc = t - t.mean()
    sxx = float(tc @ tc)
    if sxx <= 0:
        return None
    slope = float(tc @ (y - y.mean())) / sxx
    moved = abs(slope) * float(t[-1] - t[0])  # over the baseline stretch
    if slope * ev.dy < 0 and abs(slope) > 4 * ev.noise / math.sqrt(sxx) \
            and moved > UNDERSHOOT_MIN * abs(ev.dy):
        return f"the baseline moves at {slope:.3g} per s"
    return None


def refuse_moving_start(ev: EventData) -> None:
    """:class:`NotApplicable` when the output was still moving the other way at t0."""
    why = moving_the_other_way(ev)
    if why is not None:
        raise NotApplicable(f"the output was still moving the other way when the step came "
                            f"({why}): a reading that assumes rest at the step does not "
                            "apply (the least-squares fit carries the state)")


@per_event
def undershoot(ev: EventData) -> dict | None:
    """The wrong-way excursion of a step response before it first reaches half its
    change: ``{"depth", "t"}`` (depth a positive fraction of the change, time since t0),
    or None when it is within ``max(UNDERSHOOT_MIN, 5 sigma/sqrt(w))`` or within the
    averaged baseline's own wander (:func:`_smoothed_wander`: slow noise).

    The fractional response from the baseline on is averaged over a moving window of
    ``w`` samples (2 % of the event, at least 5; only when there is noise): an average
    has no negative weights, so the corner of a response that starts rising at t0 does
    not turn into a dip, as it would under Savitzky-Golay smoothing."""
    if ev.dy == 0 or not np.isfinite(ev.dy):
        return None
    h = (ev.y - ev.y0) / ev.dy
    sigma = ev.noise / abs(ev.dy)
    w = max(5, int(0.02 * h.size) | 1) if sigma > NOISE_FREE else 1
    hs = uniform_filter1d(h, w, mode="nearest") if w > 1 else h
    i0 = ev.i0
    half = np.flatnonzero(hs[i0:] >= 0.5)
    stop = i0 + (int(half[0]) if half.size else hs.size - i0)
    if stop <= i0:
        return None
    j = i0 + int(np.argmin(hs[i0:stop]))
    depth = -float(hs[j])
    # the baseline's average ends half a window before t0: later ones hold the response
    base = hs[:max(0, i0 - w // 2)]
    if depth <= max(UNDERSHOOT_MIN, 5 * sigma / np.sqrt(w), _smoothed_wander(base, w)):
        return None
    return {"depth": depth, "t": float(ev.t[j] - ev.t0)}


#: Standard deviations of the averaged baseline's wander a dip must exceed.
WANDER_SIGMAS = 4.0


def _smoothed_wander(base: np.ndarray, w: int) -> float:
    """:data:`WANDER_SIGMAS` times the scatter of the ``w``-sample moving average over the
    baseline before t0, about its straight line (0 when the baseline is shorter than
    ``3 w``). ``sigma / sqrt(w)`` is that scatter for white noise only: averaging slow
    (AR(1), 1/f) noise takes much less of it away (AR(1) phi 0.9 over 7 samples: 2.3
    times ``sigma / sqrt(w)`` measured on a baseline), and its wander after a step read
    as an inverse response on right models (issue 27 item 4)."""
    if w <= 1 or base.size < 3 * w:
        return 0.0
    x = np.arange(base.size, dtype=np.float64)
    line = np.polyval(np.polyfit(x, base, 1), x)
    return WANDER_SIGMAS * float(np.std(base - line))


@per_event
def band_exit_time(ev: EventData, band_rel: float = 0.01, band_sigma: float = 4.0
                   ) -> tuple[float, float]:
    """``(time since t0, band as a fraction of the change)`` when the output first leaves
    the band ``y0 +- max(band_rel |dy|, band_sigma sigma)`` (seed 001 "Time delay")."""
    r = normalised(ev)
    tau, hs = r.tau, r.hs
    frac = max(band_rel, band_sigma * r.sigma)
    if frac >= 0.5:
        raise NotApplicable(f"the noise band (+-{frac:.0%} of the change) is too wide to see "
                            "where the output starts to move")
    out = np.abs(hs) > frac
    if not out.any():
        raise NotApplicable("the output never leaves its noise band")
    i = int(np.argmax(out))
    if i == 0:
        return 0.0, frac
    return interp_cross(tau[i - 1], tau[i], abs(hs[i - 1]), abs(hs[i]), frac), frac


def clip_delay(raw: float) -> tuple[float, dict]:
    """``(delay, diagnostics)``: a negative computed dead time becomes 0, the time
    constants kept (ERRATA [S2] 6); the raw value is always recorded under one key for
    every method, ``delay_computed``, with ``delay_clipped`` true when it was negative, so
    grading can flag a clipped delay."""
    raw = float(raw)
    return max(0.0, raw), {"delay_computed": raw, "delay_clipped": raw < 0}
