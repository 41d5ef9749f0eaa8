"""Smith's method: a second-order model from the 20 % and 60 % points
(seed 002 section 2.4, eqs 12-13, Fig. 6).

The model is ``K/(tau^2 s^2 + 2 zeta tau s + 1)``. With ``t20``, ``t60`` the times after
the step at which the response reaches 20 % and 60 % of its change, Smith's charts
(computed exactly, :func:`~pipeline.methods.charts.smith_lookup`, ERRATA [S2] 13) give
``zeta`` from ``t20/t60`` and ``tau`` from ``t60/tau``. Then:

* ``zeta >= 1``: two real lags, eq. (12)-(13): ``T1,2 = tau (zeta +- sqrt(zeta^2 - 1))``
  (``two_lags``; computed as ``tau/sqrt(r)``, ``tau sqrt(r)`` with ``r = T2/T1`` from the
  chart, which stays accurate near ``zeta = 1`` and for large zeta);
* ``zeta < 1``: eq. (13) would give complex constants; the model is the underdamped
  ``second_order`` with ``wn = 1/tau`` (ERRATA [S2] 13);
* ``t20/t60`` at or below the first-order limit ``ln(1.25)/ln(2.5) = 0.2435`` (within a
  relative 1e-5, the precision of interpolated readings on noise-free data, so that an
  exact single lag does not come out as two lags with ``T2 = 1e-6 T1``): a single lag
  ``T = t60/ln(2.5)`` (``first_order``), the limit ``zeta -> inf`` of the chart.

No dead time: eq. (12) and the paper's tables have none (ERRATA [S2] 12).

Domain: not applicable when ``t20/t60 >= 0.5551`` (``acos(0.8)/acos(0.4)``, the undamped
limit): no second-order lag produces such a ratio, which is why the paper finds the
method "doesn't suit" its 5th-order systems (ratios 0.590, 0.564; ERRATA [S2] 13). Also
not applicable when the output does not change or never reaches 60 %, and when the
underdamped branch predicts an overshoot the response does not show (a non-oscillating
higher-order lag just below the limit would become a near-undamped oscillator).
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import NotApplicable
from ..events import EventData
from ..models import ProcessModel
from .base import normalised
from .charts import SMITH_RATIO_MAX, SMITH_RATIO_MIN, smith_lookup
from .prepared import Response
from .registry import MethodResult, register
from .second_order import Z_PEAK

#: Relative tolerance on the first-order limit of t20/t60 (reading precision).
FIRST_ORDER_TOL = 1e-5


@register(id="smith", event="step", structures=("second_order", "two_lags", "first_order"),
          references=("smith1972", "seborg1989"),
          source="seed 002 eqs 12-13 and Fig. 6 (Smith); ERRATA [S2] 12, 13",
          title="Smith (t20/t60, Smith's charts)")
def smith(ev: EventData) -> MethodResult:
    """Second-order model from ``t20/t60`` and ``t60/tau`` (seed 002 eqs 12-13).

    See the module docstring for the model cases and the domain.
    """
    resp = normalised(ev)
    t20 = resp.crossing(0.20)
    t60 = resp.crossing(0.60)
    if not (t60 > t20 > 0):
        raise NotApplicable("the 20 % and 60 % points are not separated after the step")
    ratio = t20 / t60
    diag = {"t0": ev.t0, "t20": ev.t0 + t20, "y20": ev.y0 + 0.20 * ev.dy,
            "t60": ev.t0 + t60, "y60": ev.y0 + 0.60 * ev.dy, "ratio_t20_t60": ratio}
    if ratio >= SMITH_RATIO_MAX:
        raise NotApplicable(
            f"t20/t60 = {ratio:.4f} above what any second-order lag can produce "
            f"({SMITH_RATIO_MAX:.4f}): the process is of higher order")
    K = ev.dy / ev.du
    rd = smith_lookup(ratio)
    if rd.first_order or ratio <= SMITH_RATIO_MIN * (1.0 + FIRST_ORDER_TOL):
        T = t60 / math.log(2.5)
        diag |= {"zeta": math.inf, "case": "first-order limit"}
        return MethodResult(ProcessModel("first_order", {"K": K, "T": T, "delay": 0.0}), diag)
    tc = t60 / rd.t60_over_tau
    diag |= {"zeta": rd.zeta, "t60_over_tau": rd.t60_over_tau, "tau": tc}
    if rd.lag_ratio is not None:  # zeta >= 1: eq. (13)
        r = rd.lag_ratio
        diag |= {"case": "two real lags", "lag_ratio": r}
        model = ProcessModel("two_lags", {"K": K, "T1": tc / math.sqrt(r),
                                          "T2": tc * math.sqrt(r), "delay": 0.0})
        return MethodResult(model, diag)
    diag["case"] = "underdamped"
    diag |= _check_overshoot(resp, rd.zeta, tc)
    model = ProcessModel("second_order", {"K": K, "zeta": rd.zeta, "wn": 1.0 / tc,
                                          "delay": 0.0})
    return MethodResult(model, diag)


def _check_overshoot(resp: Response, zeta: float, tc: float) -> dict:
    """The underdamped branch predicts an overshoot ``M = exp(-pi zeta/sqrt(1 - zeta^2))``
    at ``t = pi tc/sqrt(1 - zeta^2)``; a response that does not show it is not that
    oscillator (a higher-order lag whose t20/t60 lies just below the undamped limit, or
    noise on the readings, would become a near-undamped model). Not applicable when the
    predicted overshoot is significant (above ``3 sqrt(2)`` times the marginal noise,
    the overshoot test of :func:`~pipeline.methods.second_order.check_oscillation`) and
    the response's largest excursion above its final value is less than half of it, or
    when the window ends before the predicted peak."""
    tau, sigma = resp.tau, resp.sigma
    M = math.exp(-math.pi * zeta / math.sqrt(1.0 - zeta**2))
    t_peak = math.pi * tc / math.sqrt(1.0 - zeta**2)
    if M <= Z_PEAK * math.sqrt(2.0) * sigma:
        return {"overshoot_predicted": M}
    if t_peak > tau[-1]:
        raise NotApplicable(f"zeta = {zeta:.3g} predicts an overshoot of {M:.1%} at "
                            f"{t_peak:.4g} s, after the end of the window")
    seen = float(np.max(resp.hs[tau >= 0.5 * t_peak])) - 1.0
    if seen < 0.5 * M:
        raise NotApplicable(
            f"t20/t60 gives zeta = {zeta:.3g}, an oscillator overshooting by {M:.1%}, but the "
            f"response overshoots by at most {max(seen, 0.0):.1%}: it does not oscillate "
            "(a higher-order lag near the undamped limit)")
    return {"overshoot_predicted": M, "overshoot_seen": seen}
