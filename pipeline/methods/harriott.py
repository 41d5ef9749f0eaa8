"""Harriott's method: two lags and a dead time from t73 and one chart reading
(seed 002 section 2.3, eqs 9-11, Fig. 4).

``K e^{-Td s}/((T_H1 s+1)(T_H2 s+1))`` (eq. 9):

1. ``Td = 1.937 t33 - 0.937 t70`` (eq. 11, Viteckova's second-order delay), set to 0
   when negative;
2. the fractional responses of all two-lag systems plotted against ``t/(T_H1+T_H2)``
   nearly cross at 73 % near 1.3, so ``S = T_H1 + T_H2 = (t73 - Td)/1.3`` (eq. 10), with
   times measured from ``t0 + Td`` (ERRATA [S2] 9; this reproduces the paper's sums
   1.657 / 2.133 in Tab. 7/8);
3. the fractional response ``y1`` at ``t1 = Td + 0.5 S`` (ERRATA [S2] 8: the paper calls
   the response "t1") gives ``r = T_H1/S`` on Harriott's chart, computed exactly
   (:func:`~pipeline.methods.charts.harriott_r`, ERRATA [S2] 7, 27);
4. ``T_H1 = r S``, ``T_H2 = (1 - r) S``. In the model ``T1`` is the larger constant
   (``(1 - r) S``) and ``T2`` the smaller one.

Domain (seed 002: "if the fractional response is less than 0.26 or greater than 0.39 at
this point, the method is not applicable"): the exact chart spans ``[0.2642, 0.3935]``
(0.26 and 0.39 are its rounding, ERRATA [S2] 7). Not applicable when ``y1 > 0.3935``
(no two-lag system reaches it; a single lag gives 0.3956 with the 1.3 rule, so the
paper's Tab. 4 Harriott row is flagged, ERRATA [S2] 11) or ``y1 < 0.26``; a value in
``[0.26, 0.2642)`` is the equal-lag end read with the 1.3 rule's bias (exact x73 is
1.2933, not 1.3, for equal lags) and is clipped to ``r = 0.5``. Also not applicable
when the output does not change or never reaches 73 %.
"""

from __future__ import annotations

from ..errors import NotApplicable
from ..events import EventData
from ..models import ProcessModel
from .base import clip_delay, normalised
from .charts import (
    HARRIOTT_LEVEL,
    HARRIOTT_READ_AT,
    HARRIOTT_X73,
    HARRIOTT_Y_MAX,
    HARRIOTT_Y_MIN,
    harriott_r,
    harriott_x73,
)
from .prepared import Response
from .registry import MethodResult, register
from .viteckova import V2, read_t33_t70, two_point

#: The paper's applicability limits (section 2.3) and the chart's exact upper end.
Y_LOW = 0.26
Y_HIGH = HARRIOTT_Y_MAX


def _fixed_point(resp: Response, t73: float, delay: float, r: float,
                 iterations: int = 50) -> tuple[float, float, float, float, int]:
    """ERRATA [S2] 10 refinement: ``S = (t73 - Td)/x73(r)``, ``r = chart(y(Td + S/2))``
    repeated until ``r`` settles (a contraction: x73 varies by 2.4 % over the chart)."""
    for it in range(1, iterations + 1):
        S = (t73 - delay) / harriott_x73(r)
        t1 = delay + HARRIOTT_READ_AT * S
        y1 = resp.value_at(t1)
        r_new = harriott_r(y1)
        if abs(r_new - r) < 1e-10:
            return S, t1, y1, r_new, it
        r = r_new
    return S, t1, y1, r, iterations


@register(id="harriott", event="step", structures=("two_lags",),
          references=("harriott1964", "seborg1989"),
          source="seed 002 eqs 9-11 and Fig. 4 (Harriott); ERRATA [S2] 7-11",
          title="Harriott (t73, chart at 0.5 (T1+T2))")
def harriott(ev: EventData, exact_x73: bool = False) -> MethodResult:
    """``K e^{-Td s}/((T1 s+1)(T2 s+1))`` by Harriott's method (seed 002 eqs 9-11).

    See the module docstring for the steps and the domain: not applicable when the
    fractional response at ``Td + 0.5 (T1+T2)`` lies outside 0.26-0.3935 (the process
    needs a higher-order or an underdamped model, or is a single lag).

    ``exact_x73=True`` is the optional refinement of ERRATA [S2] 10 (not in seed 002,
    not the registered default): the 1.3 of eq. (10) is replaced by the exact
    ``t73/S`` of the chart's current ``r`` (:func:`~pipeline.methods.charts.harriott_x73`,
    1.278-1.309) and steps 2-3 are repeated to the fixed point, which removes the
    method's own bias (up to -5 % on T1 and +9 % on T2 for two distinct lags).
    """
    resp = normalised(ev)
    t33, t70 = read_t33_t70(ev)
    _, delay, raw = two_point(t33, t70, V2)
    t73 = resp.crossing(HARRIOTT_LEVEL)
    S = (t73 - delay) / HARRIOTT_X73
    if not S > 0:
        raise NotApplicable("the 73 % point lies inside the dead time")
    t1 = delay + HARRIOTT_READ_AT * S
    y1 = resp.value_at(t1)
    diag = {"t0": ev.t0, "t33": ev.t0 + t33, "t70": ev.t0 + t70, **clip_delay(raw)[1],
            "t73": ev.t0 + t73, "y73": ev.y0 + HARRIOTT_LEVEL * ev.dy, "sum_T": S,
            "t1": ev.t0 + t1, "y1": ev.y0 + y1 * ev.dy, "fractional_response": y1}
    if not Y_LOW <= y1 <= Y_HIGH:
        raise NotApplicable(
            f"fractional response {y1:.4f} at t1 = Td + 0.5 (T1+T2) is outside Harriott's "
            f"range 0.26-0.39 (exact chart {HARRIOTT_Y_MIN:.4f}-{HARRIOTT_Y_MAX:.4f}): "
            + ("the process looks like a single lag" if y1 > Y_HIGH else
               "seed 002: the process needs a higher-order or an underdamped model"))
    r = harriott_r(y1)
    if exact_x73:
        S, t1, y1, r, it = _fixed_point(resp, t73, delay, r)
        diag |= {"sum_T": S, "t1": ev.t0 + t1, "y1": ev.y0 + y1 * ev.dy,
                 "fractional_response": y1, "x73": harriott_x73(r), "iterations": it}
    diag |= {"chart_r": r, "chart_clipped": y1 < HARRIOTT_Y_MIN}
    model = ProcessModel("two_lags", {"K": ev.dy / ev.du, "T1": (1.0 - r) * S, "T2": r * S,
                                      "delay": delay})
    return MethodResult(model, diag)
