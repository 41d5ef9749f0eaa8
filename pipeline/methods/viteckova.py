"""Viteckova's two-point methods: the 33 % and 70 % points (seed 002 section 2.1).

The model's step response passes through the measured one at 33 % and 70 % of the
change. With ``t33``, ``t70`` the crossing times after the step:

* first order, eqs (1)-(3): ``K e^{-Td s}/(tau s+1)``, ``Td = 1.498 t33 - 0.498 t70``,
  ``tau = 1.245 (t70 - t33)``;
* second order, eqs (4)-(5): ``K e^{-Td s}/(tau s+1)^2``, ``Td = 1.937 t33 - 0.937 t70``,
  ``tau = 0.794 (t70 - t33)`` (ERRATA [S2] 5: the paper writes tau_V1 for tau_V2 and
  leaves the delay formula unnumbered).

The constants are the exact two-point solutions rounded to 3 digits
(``1/(x70 - x33)`` and ``x33/(x70 - x33)`` for the unit-lag quantile times x33, x70).
A negative computed delay is set to 0 and tau kept (ERRATA [S2] 6, as the paper's Tab. 4).
"""

from __future__ import annotations

from ..errors import NotApplicable
from ..events import EventData
from ..models import ProcessModel
from .base import clip_delay, normalised
from .prepared import per_event
from .registry import MethodResult, register

#: eq. (2)/(3): Td = a t33 - b t70, tau = c (t70 - t33), first order.
V1 = (1.498, 0.498, 1.245)
#: eq. (4)/(5) and the unnumbered delay formula, second order (equal lags).
V2 = (1.937, 0.937, 0.794)


@per_event
def read_t33_t70(ev: EventData) -> tuple[float, float]:
    """``(t33, t70)``: times since t0 where the response reaches 33 % and 70 % (read once
    per event: both Viteckova methods and Harriott's use them)."""
    r = normalised(ev)
    t33 = r.crossing(0.33)
    t70 = r.crossing(0.70)
    if not t70 > t33:
        raise NotApplicable("the 70 % point does not come after the 33 % point")
    return t33, t70


def two_point(t33: float, t70: float, constants: tuple[float, float, float]
              ) -> tuple[float, float, float]:
    """``(tau, delay, raw_delay)`` from the two readings; a negative delay becomes 0."""
    a, b, c = constants
    raw = a * t33 - b * t70
    return c * (t70 - t33), clip_delay(raw)[0], raw


def _diagnostics(ev: EventData, t33: float, t70: float, raw: float) -> dict:
    return {"t0": ev.t0, "t33": ev.t0 + t33, "y33": ev.y0 + 0.33 * ev.dy,
            "t70": ev.t0 + t70, "y70": ev.y0 + 0.70 * ev.dy,
            **clip_delay(raw)[1]}


@register(id="viteckova1", event="step", structures=("first_order",),
          references=("viteckova2004",),
          source="seed 002 eqs 1-3 (Viteckova, first order); ERRATA [S2] 5, 6",
          title="Viteckova, first order (t33, t70)")
def viteckova1(ev: EventData) -> MethodResult:
    """``K e^{-Td s}/(tau s+1)`` from ``t33`` and ``t70`` (seed 002 eqs 1-3).

    ``K = dy/du``; ``Td = 1.498 t33 - 0.498 t70`` (eq. 2), clamped at 0 with tau kept
    (ERRATA [S2] 6); ``tau = 1.245 (t70 - t33)`` (eq. 3).

    Domain: not applicable when the output does not change measurably or never reaches
    70 % of its change in the window.
    """
    t33, t70 = read_t33_t70(ev)
    T, delay, raw = two_point(t33, t70, V1)
    model = ProcessModel("first_order", {"K": ev.dy / ev.du, "T": T, "delay": delay})
    return MethodResult(model, _diagnostics(ev, t33, t70, raw))


@register(id="viteckova2", event="step", structures=("n_lags",),
          references=("viteckova2004",),
          source="seed 002 eqs 4-5 (Viteckova, second order); ERRATA [S2] 5, 6",
          title="Viteckova, second order (t33, t70)")
def viteckova2(ev: EventData) -> MethodResult:
    """``K e^{-Td s}/(tau s+1)^2`` from ``t33`` and ``t70`` (seed 002 eqs 4-5).

    ``K = dy/du``; ``Td = 1.937 t33 - 0.937 t70``, clamped at 0 with tau kept
    (ERRATA [S2] 6); ``tau = 0.794 (t70 - t33)`` (eq. 5, ERRATA [S2] 5). The model is
    ``n_lags`` with ``n = 2``.

    Domain: as :func:`viteckova1`.
    """
    t33, t70 = read_t33_t70(ev)
    T, delay, raw = two_point(t33, t70, V2)
    model = ProcessModel("n_lags", {"K": ev.dy / ev.du, "T": T, "n": 2, "delay": delay})
    return MethodResult(model, _diagnostics(ev, t33, t70, raw))
