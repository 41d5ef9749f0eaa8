"""Sundaresan & Krishnaswamy's two-point method: 35.3 % and 85.3 % (seed 002 section 2.6).

``K e^{-Td s}/(tau s+1)`` (eq. 22) with ``Td = 1.3 t35.3 - 0.29 t85.3`` (eq. 23) and
``tau = 0.67 (t85.3 - t35.3)`` (eq. 24); ``t35.3``, ``t85.3`` are the times after the step
at which the response reaches 35.3 % and 85.3 % of its change. For an exact first-order
lag these are ``0.436 tau`` and ``1.921 tau`` (``-ln(1 - p)``), which the constants invert
to 3 digits. A negative computed delay is set to 0, tau kept (seed 002 section 2.6,
ERRATA [S2] 6). ERRATA [S2] 30: "transform function" means transfer function.
"""

from __future__ import annotations

from ..errors import NotApplicable
from ..events import EventData
from ..models import ProcessModel
from .base import clip_delay, normalised
from .registry import MethodResult, register

LEVEL_LOW = 0.353
LEVEL_HIGH = 0.853


@register(id="sundaresan", event="step", structures=("first_order",),
          references=("sundaresan1978",),
          source="seed 002 eqs 22-24 (Sundaresan & Krishnaswamy)",
          title="Sundaresan & Krishnaswamy (t35.3, t85.3)")
def sundaresan(ev: EventData) -> MethodResult:
    """``K e^{-Td s}/(tau s+1)`` from ``t35.3`` and ``t85.3`` (seed 002 eqs 22-24).

    ``K = dy/du``; ``Td = 1.3 t35.3 - 0.29 t85.3`` (eq. 23), clamped at 0;
    ``tau = 0.67 (t85.3 - t35.3)`` (eq. 24).

    Domain: not applicable when the output does not change measurably or never reaches
    85.3 % of its change in the window.
    """
    r = normalised(ev)
    t1 = r.crossing(LEVEL_LOW)
    t2 = r.crossing(LEVEL_HIGH)
    if not t2 > t1:
        raise NotApplicable("the 85.3 % point does not come after the 35.3 % point")
    raw = 1.3 * t1 - 0.29 * t2
    T = 0.67 * (t2 - t1)
    delay, ddiag = clip_delay(raw)
    model = ProcessModel("first_order", {"K": ev.dy / ev.du, "T": T, "delay": delay})
    diag = {"t0": ev.t0, "t35_3": ev.t0 + t1, "y35_3": ev.y0 + LEVEL_LOW * ev.dy,
            "t85_3": ev.t0 + t2, "y85_3": ev.y0 + LEVEL_HIGH * ev.dy,
            **ddiag}
    return MethodResult(model, diag)
