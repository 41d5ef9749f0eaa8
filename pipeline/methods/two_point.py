"""First-order step method from two read points (seed 000 section I)."""

from __future__ import annotations

import math

import numpy as np

from ..errors import NotApplicable
from ..events import EventData
from ..models import ProcessModel
from .base import clip_delay, normalised
from .registry import MethodResult, register

#: Default read points, as fractions of the output change: both on the steep, well
#: conditioned part of the rise (below ~20 % the dead time and noise dominate, above ~85 %
#: the slope is too small for a precise time reading).
LEVELS: tuple[float, float] = (0.30, 0.80)


@register(id="first_order_two_point", event="step", structures=("first_order",),
          references=("rake1980", "seborg1989"),
          source="seed 000 section I (two points (t1, y(t1)), (t2, y(t2)) on the step "
                 "response); ERRATA [S0] 5 (k -> y_ss), [S1] 14 (implied dead time)",
          title="First order, two read points")
def first_order_two_point(ev: EventData, levels: tuple[float, float] = LEVELS
                          ) -> MethodResult:
    """K e^{-delay s}/(Ts+1) from two points on the step response (seed 000, section I).

    Seed 000 divides the two equations ``y(t_i) = k (1 - e^{-t_i/tau})`` to get

        tau = (t2 - t1) / ln((y(t1) - k) / (y(t2) - k)).

    With ``k`` replaced by the steady state and ``y`` taken relative to ``y0`` (ERRATA
    [S0] 5) the formula holds for any ``y0``, step amplitude, ``t0`` and dead time. The
    read points are the times ``t1``, ``t2`` when the fractional response
    ``h = (y - y0)/(y_ss - y0)`` reaches ``levels = (h1, h2)`` (default 30 % and 80 %),
    read with :func:`~pipeline.signal.crossing_time` (noise-robust):

        T = (t2 - t1) / ln((1 - h1) / (1 - h2)),
        K = (y_ss - y0) / (u_ss - u0)                      (seed 000 "Notes", seed 001),
        delay = t1 - T ln(1 / (1 - h1))                    (ERRATA [S1] 14).

    The two points fix the dead time exactly: a delayed lag passes ``h1`` at
    ``delay + T ln(1/(1 - h1))``. A negative implied delay (a response faster than a
    first-order lag at ``h1``, e.g. noise or a different structure) is reported in the
    diagnostics (``delay_computed``, ``delay_clipped``) and set to zero in the model,
    keeping ``T`` (ERRATA [S2] 6).

    Domain: a step event whose output changes measurably and reaches both levels in the
    window; otherwise ``not_applicable``. Works for negative steps and any ``y0``.
    """
    h1, h2 = float(levels[0]), float(levels[1])
    if not 0.0 < h1 < h2 < 1.0:
        raise NotApplicable(f"read levels {levels} must satisfy 0 < h1 < h2 < 1")
    r = normalised(ev)
    K = ev.dy / ev.du
    t1 = r.crossing(h1)
    i1 = int(np.searchsorted(r.tau, t1))
    t2 = r.crossing(h2, start=min(i1, r.tau.size - 1))
    if not t2 > t1:
        raise NotApplicable("the two read points are not in order (response not rising)")
    T = (t2 - t1) / math.log((1.0 - h1) / (1.0 - h2))
    delay, ddiag = clip_delay(t1 + T * math.log1p(-h1))
    diag = {"t0": ev.t0, "levels": [h1, h2],
            "t_read1": ev.t0 + t1, "y_read1": ev.y0 + h1 * ev.dy,
            "t_read2": ev.t0 + t2, "y_read2": ev.y0 + h2 * ev.dy,
            "settled": ev.settled, **ddiag}
    return MethodResult(ProcessModel("first_order", {"K": K, "T": T, "delay": delay}), diag)
