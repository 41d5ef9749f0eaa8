"""First-order step methods: the 63.2 % point (seed 001) with dead time."""

from __future__ import annotations

import math

from ..events import EventData
from ..models import ProcessModel
from .base import band_exit_time, clip_delay, normalised
from .registry import MethodResult, register

LEVEL_T = 0.632  # seed 001 writes 0.632 (ERRATA [S1] 13: 1 - e^-1 = 0.63212)


@register(id="first_order", event="step", structures=("first_order",),
          references=("rake1980", "busoniu"),
          source="seed 001 'General algorithm' (63.2 % point, nonzero u0, y0, t0) and "
                 "'Time delay'; seed 000 section I",
          title="First order, 63.2 % point")
def first_order(ev: EventData, level: float = LEVEL_T) -> MethodResult:
    """K/(Ts+1) e^{-delay s} from a step (seed 001, "General algorithm").

    1. ``K = (y_ss - y0)/(u_ss - u0)``.
    2. ``t1``: the output has risen by ``level`` (0.632) of its change; ``T = t1 - t0``
       minus the dead time.

    Dead time (seed 001 "Time delay", ERRATA [S1] 14): the output leaves its noise band
    of fraction ``c`` at ``t_e``. A delayed lag leaves it at ``delay + T ln(1/(1-c))``, so
    with ``T = t1 - t0 - delay`` the delay is ``(t_e - g t1)/(1 - g)``, ``g = ln(1/(1-c))``
    (times since t0), clamped at zero.

    Not applicable when the output does not change or never reaches the level.
    """
    r = normalised(ev)
    K = ev.dy / ev.du
    t1 = r.crossing(level)
    t_e, frac = band_exit_time(ev)
    g = -math.log1p(-frac)
    delay, ddiag = clip_delay((t_e - g * t1) / (1.0 - g))
    T = t1 - delay
    if T <= 0:
        from ..errors import NotApplicable

        raise NotApplicable("the 63.2 % point lies inside the dead time")
    diag = {"t0": ev.t0, "t63": ev.t0 + t1, "y63": ev.y0 + level * ev.dy,
            "t_band_exit": ev.t0 + t_e, "band_fraction": frac,
            "settled": ev.settled, **ddiag}
    return MethodResult(ProcessModel("first_order", {"K": K, "T": T, "delay": delay}), diag)
