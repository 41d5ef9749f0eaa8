"""Strejc's method: the inflection tangent, then two lags or n equal lags
(seed 002 section 2.5, eqs 14-21, Tables 2 and 3).

The tangent at the inflection point of the step response meets the initial level at
``Tu`` (after the step) and the final level ``Tn`` later; ``tu_tn_ratio = Tu/Tn``
(eqs 14, 20; ERRATA [S2] 22 names the quantities apart: the paper calls this ratio tau
and the two-lag ratio T). ERRATA [S2] 14: the paper's cases "tau < 0" / "tau >= 0" are
``Tu/Tn < 0.104`` / ``>= 0.104`` (0.104 is Table 3's n = 2 entry; a single lag has 0):

a) ``Tu/Tn < 0.104``, two lags ``K/((T1 s+1)(T2 s+1))`` (eq. 15):
   ``S = T1 + T2 = t72/1.2564`` (eq. 16, ``t72`` where the response reaches 72 %,
   ERRATA [S2] 17: "as written"); ``t2 = 0.3574 S`` (eq. 17); ``y(t2)`` on Table 2 gives
   ``r = T2/T1`` (computed exactly, :func:`~pipeline.methods.charts.strejc_ratio`,
   clipped to [0, 1], ERRATA [S2] 15); ``T1 = S/(1+r)``, ``T2 = r S/(1+r)`` (eq. 18,
   reported both ways, ERRATA [S2] 16). ``r = 0`` is a single lag ``K/(S s+1)``
   (``first_order``), as the paper's Tab. 4.
b) ``Tu/Tn >= 0.104``, n equal lags ``K/(T s+1)^n`` (eq. 19): ``n`` from the printed
   Tu/Tn column of Table 3 (:data:`~pipeline.methods.charts.STREJC_TABLE`) by the floor
   rule, the largest n with ``Tu/Tn(n) <= tu_tn_ratio + tol`` (ERRATA [S2] 19);
   ``t_i`` where the response reaches ``y_i(n)`` (ERRATA [S2] 20), with the exact
   inflection ordinate ``y_i(n) = P(n, n-1)`` (ERRATA [S2] 18: printed 0.327/0.359 for
   n = 3/4 are misprints); ``T = t_i/(n - 1)`` (eq. 21). No dead time (the classic
   variant that puts the remainder into a delay is not in seed 002).

``tol`` is 1e-3 on noise-free data (ERRATA [S2] 19: a true (Ts+1)^n sits exactly on a
rounded table entry, e.g. 0.4103 for the printed 0.41). On noisy data the ratio is
uncertain by its standard error ``se`` (from the local fit below) and ``tol =
max(1e-3, 3 se)``, so an exact n-lag plant is sent one order down by noise in fewer
than ~0.5 % of records (one-sided 3 se plus the fit's small negative bias).

The inflection tangent: noise-free, the inflection of the cubic interpolating spline
(exact to ``O(dt^3)``: n = 4 on 1/(s+1)^4 sampled at 0.05 s and at 0.2 s). Noisy, a
rough maximum of a Savitzky-Golay derivative, refined by a least-squares cubic through
the raw samples within ``+-0.3/slope`` of it (about 5 % to 60 % of the rise for
2 <= n <= 10), re-centred up to three times; the tangent is taken at the cubic's
inflection. ``Tu/Tn = m t_i - y_i`` is stationary in the inflection time, so only the
slope ``m`` matters to first order.

Domain: not applicable when the output does not change measurably, never reaches 72 %
(case a) or ``y_i`` (case b), or has no rising slope.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.interpolate import CubicSpline

from ..errors import NotApplicable
from ..events import EventData
from ..models import ProcessModel
from ..signal import NOISE_FREE, savgol
from .base import normalised
from .charts import (
    STREJC_LEVEL_SUM,
    STREJC_READ_AT,
    STREJC_TABLE,
    STREJC_X72,
    strejc_ratio,
    strejc_yi_exact,
)
from .registry import MethodResult, register

#: ERRATA [S2] 14: case (a) below Table 3's n = 2 entry.
CASE_A_BELOW = STREJC_TABLE[0][1]
#: ERRATA [S2] 19: floor-rule tolerance on noise-free data.
FLOOR_TOL = 1e-3
#: Half-width of the local cubic fit, in units of 1/slope (noisy data).
FIT_HALF_WIDTH = 0.3


@dataclass(frozen=True)
class Tangent:
    """The inflection tangent: point ``(t_i, y_i)`` (time since t0, fraction), slope
    ``m`` (fraction per second), ``Tu``, ``Tn`` and the standard error of ``Tu/Tn``."""

    t_i: float
    y_i: float
    m: float
    tu: float
    tn: float
    se: float = 0.0

    @property
    def ratio(self) -> float:
        return self.tu / self.tn


def inflection_tangent(tau: np.ndarray, h: np.ndarray, sigma: float) -> Tangent:
    """The tangent at the point of steepest rise of ``h`` (see the module docstring)."""
    if tau.size < 5:
        raise NotApplicable("too few samples after the step to draw a tangent")
    if sigma <= NOISE_FREE:
        t_i, m = _max_slope_noise_free(tau, h)
        y_i, se = float(np.interp(t_i, tau, h)), 0.0
    else:
        t_i, y_i, m, se = _max_slope_noisy(tau, h, sigma)
    if not (m > 0 and math.isfinite(m)):
        raise NotApplicable("the response has no rising slope for an inflection tangent")
    tu = max(0.0, t_i - y_i / m)
    return Tangent(t_i, y_i, m, tu, 1.0 / m, se)


def _max_slope_noise_free(tau: np.ndarray, h: np.ndarray) -> tuple[float, float]:
    """Inflection of the cubic interpolating spline through the samples: its second
    derivative is piecewise linear, so the inflection (a sign change from + to -) and the
    slope there are exact for the spline. A finite-difference slope refined by a parabola
    is biased by ``O(dt^2)`` at coarse sampling (on 1/(s+1)^4 sampled at 0.2 s it read
    Tu/Tn = 0.3179 < 0.319 and gave n = 3); the spline's slope error is ``O(dt^3)``
    (0.3192 at 0.2 s, n = 4)."""
    cs = CubicSpline(tau, h)
    d2 = cs(tau, 2)
    j = int(np.argmax(np.gradient(h, tau)))
    sign = np.flatnonzero((d2[:-1] > 0) & (d2[1:] <= 0))
    if sign.size == 0:
        return float(tau[j]), float(cs(tau[j], 1))
    # the sign change nearest the steepest sample; linear root of d2 between the knots
    k = int(sign[np.argmin(np.abs(sign - j))])
    t_i = float(tau[k] + d2[k] * (tau[k + 1] - tau[k]) / (d2[k] - d2[k + 1]))
    return t_i, float(cs(t_i, 1))


def _max_slope_noisy(tau: np.ndarray, h: np.ndarray, sigma: float
                     ) -> tuple[float, float, float, float]:
    dt = float(np.median(np.diff(tau)))
    w = min(max(7, int(0.02 * h.size) | 1), h.size if h.size % 2 else h.size - 1)
    d = savgol(h, w, deriv=1, delta=dt) if w >= 7 else np.gradient(h, tau)
    j = int(np.argmax(d))
    tc, m = float(tau[j]), float(d[j])
    if not m > 0:
        raise NotApplicable("the response has no rising slope for an inflection tangent")
    y_i, se = float(np.interp(tc, tau, h)), 0.0
    for _ in range(3):
        half = max(FIT_HALF_WIDTH / m, 5 * dt)
        sel = np.abs(tau - tc) <= half
        if sel.sum() < 8:
            break
        x = tau[sel] - tc
        p, cov = np.polyfit(x, h[sel], 3, cov=True)
        dp = np.polyder(p)
        # the inflection of the cubic (slope maximum) inside the window, else the steepest edge
        xs = [-p[1] / (3 * p[0])] if p[0] < 0 else []
        xs = [v for v in xs if x[0] <= v <= x[-1]] or [x[0], x[-1]]
        xi = float(max(xs, key=lambda v: np.polyval(dp, v)))
        tc_new = tc + xi
        m_new = float(np.polyval(dp, xi))
        if not m_new > 0:
            break
        y_i = float(np.polyval(p, xi))
        # se of m t_i - y_i with t_i held (the ratio is stationary in t_i): gradient wrt
        # the coefficients (c3, c2, c1, c0) of the cubic at xi
        g = np.array([3 * xi**2 * tc_new - xi**3, 2 * xi * tc_new - xi**2,
                      tc_new - xi, -1.0])
        se = float(math.sqrt(max(g @ cov @ g, 0.0)))
        converged = abs(xi) < dt
        tc, m = tc_new, m_new
        if converged:
            break
    return tc, y_i, m, se


def strejc_order(ratio: float, tol: float = FLOOR_TOL) -> tuple[int, float, float]:
    """Table 3 floor rule: ``(n, printed Tu/Tn(n), printed y_i(n))`` of the largest n with
    ``Tu/Tn(n) <= ratio + tol`` (n = 2 at the least)."""
    row = STREJC_TABLE[0]
    for r in STREJC_TABLE:
        if r[1] <= ratio + tol:
            row = r
    return row


@register(id="strejc", event="step", structures=("n_lags", "two_lags", "first_order"),
          references=("strejc1959",),
          source="seed 002 eqs 14-21, Tables 2-3 (Strejc); ERRATA [S2] 14-22",
          title="Strejc (inflection tangent Tu/Tn)")
def strejc(ev: EventData) -> MethodResult:
    """Strejc's method (seed 002 eqs 14-21): see the module docstring for both cases
    and the domain."""
    resp = normalised(ev)
    tau, h, sigma = resp
    tg = inflection_tangent(tau, h, sigma)
    ratio = tg.ratio
    K = ev.dy / ev.du
    diag = {"t0": ev.t0, "t_inflection": ev.t0 + tg.t_i,
            "y_inflection": ev.y0 + tg.y_i * ev.dy, "slope": tg.m * ev.dy,
            "tu": tg.tu, "tn": tg.tn, "tu_tn_ratio": ratio, "tu_tn_ratio_se": tg.se,
            "t_tangent_start": ev.t0 + tg.tu, "t_tangent_end": ev.t0 + tg.tu + tg.tn}
    if ratio < CASE_A_BELOW:
        t72 = resp.crossing(STREJC_LEVEL_SUM)
        S = t72 / STREJC_X72
        t2 = STREJC_READ_AT * S
        y2 = resp.value_at(t2)
        r = strejc_ratio(y2)
        diag |= {"case": "a", "t72": ev.t0 + t72, "y72": ev.y0 + STREJC_LEVEL_SUM * ev.dy,
                 "sum_T": S, "t2": ev.t0 + t2, "y2": ev.y0 + y2 * ev.dy,
                 "fractional_response_t2": y2, "t_ratio": r,
                 "t_ratio_inverse": 1.0 / r if r > 0 else math.inf}
        if r == 0.0:
            return MethodResult(ProcessModel("first_order", {"K": K, "T": S, "delay": 0.0}),
                                diag)
        model = ProcessModel("two_lags", {"K": K, "T1": S / (1.0 + r), "T2": r * S / (1.0 + r),
                                          "delay": 0.0})
        return MethodResult(model, diag)
    tol = max(FLOOR_TOL, 3.0 * tg.se)
    n, ratio_n, yi_printed = strejc_order(ratio, tol)
    yi = strejc_yi_exact(n)
    t_i = resp.crossing(yi)
    if not t_i > 0:
        raise NotApplicable("the inflection ordinate is reached at the step itself")
    T = t_i / (n - 1)
    diag |= {"case": "b", "n": n, "table_tu_tn": ratio_n, "floor_tolerance": tol,
             "y_i": yi, "y_i_printed": yi_printed, "t_i": ev.t0 + t_i,
             "y_ti": ev.y0 + yi * ev.dy}
    model = ProcessModel("n_lags", {"K": K, "T": T, "n": n, "delay": 0.0})
    return MethodResult(model, diag)
