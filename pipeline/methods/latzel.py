"""Latzel's method: equal lags from the 10, 50 and 90 % points (seed 002 section 2.2).

``K/(tau s+1)^n`` (eq. 6). With ``t10, t50, t90`` the times after the step at which the
response reaches 10, 50 and 90 % of its change (ERRATA [S2] 2: the paper's "70 %" is
90 %):

1. ``mu = t10/t90`` (eq. 8);
2. the row of Table 1 (:data:`~pipeline.methods.charts.LATZEL_TABLE`) whose ``mu_a`` is
   nearest gives ``n`` and ``alpha10, alpha50, alpha90``; below the first row
   (first-order-like data) the nearest row is ``n = 2`` (ERRATA [S2] 4), and the
   ``n = 2.5`` row gives a gamma-type model with non-integer n;
3. ``tau = (alpha10 t10 + alpha50 t50 + alpha90 t90)/3`` (eq. 7 with the missing factor
   1/3, ERRATA [S2] 1: each ``alpha_p t_p`` alone equals tau for an exact (tau s+1)^n).
"""

from __future__ import annotations

from ..errors import NotApplicable
from ..events import EventData
from ..models import ProcessModel
from .base import normalised
from .charts import LATZEL_TABLE
from .registry import MethodResult, register

LEVELS = (0.10, 0.50, 0.90)


def latzel_row(mu: float) -> tuple[float, float, float, float, float]:
    """Table 1 row with ``mu_a`` nearest to ``mu`` (ties: the lower order)."""
    return min(LATZEL_TABLE, key=lambda row: (abs(row[0] - mu), row[1]))


@register(id="latzel", event="step", structures=("n_lags",),
          references=("latzel",),
          source="seed 002 eqs 6-8 and Table 1 (Latzel); ERRATA [S2] 1-4",
          title="Latzel (t10, t50, t90, Table 1)")
def latzel(ev: EventData) -> MethodResult:
    """``K/(tau s+1)^n`` from ``t10, t50, t90`` and Table 1 (seed 002 eqs 6-8).

    ``K = dy/du``; ``mu = t10/t90`` selects the nearest Table 1 row (n, alphas);
    ``tau = (alpha10 t10 + alpha50 t50 + alpha90 t90)/3``. The model has no delay.

    Domain: not applicable when the output does not change measurably or never reaches
    90 % of its change in the window. ``mu`` beyond the table ends maps to n = 2 or
    n = 20 (nearest row).
    """
    r = normalised(ev)
    t10, t50, t90 = (r.crossing(p) for p in LEVELS)
    if not t90 > 0:
        raise NotApplicable("the response is at 90 % already at the step: no rise to read")
    mu = t10 / t90
    mu_a, n, a10, a50, a90 = latzel_row(mu)
    T = (a10 * t10 + a50 * t50 + a90 * t90) / 3.0
    model = ProcessModel("n_lags", {"K": ev.dy / ev.du, "T": T, "n": n, "delay": 0.0})
    diag = {"t0": ev.t0,
            "t10": ev.t0 + t10, "y10": ev.y0 + 0.10 * ev.dy,
            "t50": ev.t0 + t50, "y50": ev.y0 + 0.50 * ev.dy,
            "t90": ev.t0 + t90, "y90": ev.y0 + 0.90 * ev.dy,
            "mu": mu, "mu_a": mu_a, "table_row": {"mu_a": mu_a, "n": n, "alpha10": a10,
                                                   "alpha50": a50, "alpha90": a90}}
    return MethodResult(model, diag)
