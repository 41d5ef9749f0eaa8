"""The charts and tables of seed 002 (Jakoubek), computed exactly, never digitised.

Seed 002 reads three values off printed charts that the paper does not reproduce
(ERRATA [S2] 7, 13, 15). Each chart is a property of the model it was drawn for, so it
is computed here from that model's closed-form step response
(:func:`pipeline.models.second_order_step`; two lags in a cancellation-free form of
:func:`pipeline.models.two_lag_step`):

* **Harriott's curve** (seed 002 Fig. 4, eqs 9-10; ERRATA [S2] 7, 8, 10): the fractional
  response ``y(0.5 S; r)`` of ``1/((r S s+1)((1-r) S s+1))``, ``r = T_H1/(T_H1+T_H2)`` in
  ``[0, 0.5]``, ``S = T_H1 + T_H2``. It falls from ``1 - e^-0.5 = 0.3935`` (``r = 0``) to
  ``1 - 2/e = 0.2642`` (``r = 0.5``); :func:`harriott_r` inverts it.
* **Smith's curves** (seed 002 Fig. 6, eqs 12-13; ERRATA [S2] 13): for
  ``1/(tau^2 s^2 + 2 zeta tau s + 1)``, ``t20/t60`` as a function of ``zeta`` (strictly
  decreasing from ``acos(0.8)/acos(0.4) = 0.5551`` at ``zeta -> 0`` to
  ``ln(1.25)/ln(2.5) = 0.2435`` at ``zeta -> inf``, the first-order limit) and ``t60/tau``;
  :func:`smith_lookup` inverts them.
* **Strejc's Table 2** (seed 002 eqs 16-18; ERRATA [S2] 15): ``y(0.3574 S; r)`` of
  ``1/((T1 s+1)(T2 s+1))`` with ``r = T2/T1`` in ``[0, 1]``, ``S = T1 + T2``; range
  ``[0.1610, 0.3005]``; :func:`strejc_ratio` inverts it (clipped outside).

Every forward function is a closed form (Smith's needs a root find for the crossing
times); the inverse lookups solve the forward function with :func:`scipy.optimize.brentq`,
so they are exact to ~1e-12 also where a chart is flat (Harriott near ``r = 0.5``).
Dense tables for drawing the charts are computed once (``functools.cache``).

Two printed tables are kept as data with their citation: Latzel's Table 1
(:data:`LATZEL_TABLE`) and Strejc's Table 3 (:data:`STREJC_TABLE`); the functions
:func:`latzel_row_exact` and :func:`strejc_row_exact` give their exact values for checks.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from functools import cache

import numpy as np
from scipy.optimize import brentq
from scipy.special import gammainc, gammaincinv

from ..responses import second_order_step, two_lag_step

_XTOL = 1e-14


def _tiny_to_zero(r: float) -> float:
    """A lag ratio below 1e-12 is a single lag (its response differs by < 1e-11; the
    two-lag formula would overflow in ``t/T2``)."""
    return 0.0 if r < 1e-12 else r


def _scalar(f: Callable[..., np.ndarray], t: float, *args: float) -> float:
    return float(f(np.array([t], dtype=np.float64), *args)[0])


def _lags(t: float, T1: float, T2: float) -> float:
    """Unit step response of 1/((T1 s+1)(T2 s+1)) at ``t``, without the cancellation of
    the textbook form near equal lags: ``1 - e^{-a t} (1 + a t phi((b - a) t))`` with
    ``a = 1/T1 <= b = 1/T2`` and ``phi(x) = (1 - e^{-x})/x``. Agrees with
    :func:`pipeline.models.two_lag_step` (whose form loses ~1e-16/(T1 - T2) there, enough
    to blur the charts' flat ends, Harriott r -> 0.5 and Strejc r -> 1)."""
    T1, T2 = max(T1, T2), min(T1, T2)
    if T2 <= 0.0:
        return _scalar(two_lag_step, t, T1, 0.0)
    a, b = 1.0 / T1, 1.0 / T2
    x = (b - a) * t
    phi = 1.0 if x == 0.0 else -math.expm1(-x) / x
    return 1.0 - math.exp(-a * t) * (1.0 + a * t * phi)


# =====================================================================================
# Harriott (seed 002 Fig. 4, eqs 9-10; ERRATA [S2] 7, 8, 10, 11)
# =====================================================================================

#: Fraction of ``S = T_H1 + T_H2`` at which the response is read (seed 002 section 2.3).
HARRIOTT_READ_AT = 0.5
#: The paper's "t/(T_H1+T_H2) approximately equals 1.3" at 73 % (eq. 10).
HARRIOTT_X73 = 1.3
HARRIOTT_LEVEL = 0.73
#: ``y(0.5 S)`` for ``r = 0`` (a single lag): 1 - e^-0.5 = 0.39347.
HARRIOTT_Y_MAX = -math.expm1(-0.5)
#: ``y(0.5 S)`` for ``r = 0.5`` (two equal lags): 1 - 2/e = 0.26424.
HARRIOTT_Y_MIN = 1.0 - 2.0 / math.e


def harriott_y(r: float) -> float:
    """Harriott's chart: fractional response at ``t = 0.5 S`` of
    ``1/((r S s+1)((1-r) S s+1))`` for ``r = T_H1/(T_H1+T_H2)`` in ``[0, 0.5]``."""
    r = _tiny_to_zero(float(np.clip(r, 0.0, 0.5)))
    return _lags(HARRIOTT_READ_AT, r, 1.0 - r)


def harriott_r(y: float) -> float:
    """Inverse of :func:`harriott_y`: ``r`` in ``[0, 0.5]`` (clipped outside the range)."""
    if y >= HARRIOTT_Y_MAX:
        return 0.0
    if y <= HARRIOTT_Y_MIN:
        return 0.5
    return float(brentq(lambda r: harriott_y(r) - y, 0.0, 0.5, xtol=_XTOL))


def harriott_x73(r: float) -> float:
    """Exact ``t73/S`` of the two-lag response for chart variable ``r`` (ERRATA [S2] 10:
    1.3093 for r = 0, 1.2778 for r = 0.25, 1.2933 for r = 0.5)."""
    r = float(np.clip(r, 0.0, 0.5))
    return float(brentq(lambda x: _lags(x, r, 1.0 - r) - HARRIOTT_LEVEL, 0.1, 10.0,
                        xtol=_XTOL))


@cache
def harriott_curve(n: int = 501) -> tuple[np.ndarray, np.ndarray]:
    """Dense Harriott chart ``(r, y(0.5 S; r))`` for drawing (read-only arrays)."""
    r = np.linspace(0.0, 0.5, n)
    y = np.array([harriott_y(v) for v in r])
    return _frozen(r), _frozen(y)


# =====================================================================================
# Smith (seed 002 Fig. 6, eqs 12-13; ERRATA [S2] 13)
# =====================================================================================

#: ``t20/t60`` of the undamped limit ``zeta -> 0`` (1 - cos t): acos(0.8)/acos(0.4).
SMITH_RATIO_MAX = math.acos(0.8) / math.acos(0.4)
#: ``t20/t60`` of the first-order limit ``zeta -> inf``: ln(1.25)/ln(2.5).
SMITH_RATIO_MIN = math.log(1.25) / math.log(2.5)


def _crossing(f: Callable[[float], float], level: float, hi: float) -> float:
    return float(brentq(lambda t: f(t) - level, 0.0, hi, xtol=_XTOL))


def smith_times_underdamped(zeta: float) -> tuple[float, float]:
    """``(t20/tau, t60/tau)`` of ``1/(tau^2 s^2 + 2 zeta tau s + 1)`` for ``0 <= zeta <= 1``."""
    if zeta >= 1.0:
        return smith_times_lags(1.0)
    wd = math.sqrt(1.0 - zeta * zeta)
    hi = math.pi / wd  # first peak: the response is above 1 there, monotone before it
    f = lambda t: _scalar(second_order_step, t, zeta, 1.0)  # noqa: E731
    return _crossing(f, 0.2, hi), _crossing(f, 0.6, hi)


def smith_times_lags(r: float) -> tuple[float, float]:
    """``(t20/tau, t60/tau)`` of the overdamped curve, parametrised by ``r = T2/T1`` in
    ``(0, 1]`` (``zeta = (1+r)/(2 sqrt r)``, ``tau = sqrt(T1 T2)``): well conditioned up to
    the first-order limit, where ``zeta = (T1+T2)/(2 tau)`` is not."""
    r = float(np.clip(r, 1e-300, 1.0))
    T1 = 1.0 / math.sqrt(r)  # tau = sqrt(T1 T2) = 1
    T2 = math.sqrt(r)
    f = lambda t: _lags(t, T1, T2)  # noqa: E731
    hi = 40.0 * (T1 + T2)
    return _crossing(f, 0.2, hi), _crossing(f, 0.6, hi)


def _ratio_lags(r: float) -> float:
    """``t20/t60`` of two lags with ratio ``r = T2/T1`` (``r = 0``: first-order limit)."""
    if r <= 0.0:
        return SMITH_RATIO_MIN
    t20, t60 = smith_times_lags(r)
    return t20 / t60


def _ratio_zeta(zeta: float) -> float:
    if zeta <= 0.0:
        return SMITH_RATIO_MAX
    t20, t60 = smith_times_underdamped(zeta)
    return t20 / t60


#: ``t20/t60`` at critical damping ``zeta = 1`` (two equal lags): 0.40765.
SMITH_RATIO_CRITICAL = float(gammaincinv(2.0, 0.2) / gammaincinv(2.0, 0.6))


def smith_ratio(zeta: float) -> float:
    """Smith's chart: ``t20/t60`` of ``1/(tau^2 s^2 + 2 zeta tau s + 1)`` (zeta >= 0)."""
    if zeta <= 1.0:
        return _ratio_zeta(zeta)
    return _ratio_lags(_lag_ratio_from_zeta(zeta))


def smith_t60_over_tau(zeta: float) -> float:
    """Smith's second chart: ``t60/tau`` as a function of ``zeta`` (zeta > 0)."""
    if zeta <= 1.0:
        return smith_times_underdamped(zeta)[1]
    return smith_times_lags(_lag_ratio_from_zeta(zeta))[1]


def _lag_ratio_from_zeta(zeta: float) -> float:
    s = math.sqrt(zeta * zeta - 1.0)
    return (zeta - s) / (zeta + s) if zeta < 1e8 else 1.0 / (4.0 * zeta * zeta)


@dataclass(frozen=True)
class SmithReading:
    """The reading of Smith's charts for one ratio ``t20/t60``.

    ``zeta`` and ``t60_over_tau`` as on Fig. 6; for ``zeta >= 1`` also ``lag_ratio``
    ``r = T2/T1`` (eq. 13: ``T1,2 = tau (zeta +- sqrt(zeta^2 - 1))``). ``first_order`` is
    set at (or below) the first-order limit, where ``tau`` is undefined.
    """

    ratio: float
    zeta: float
    t60_over_tau: float
    lag_ratio: float | None
    first_order: bool = False


def smith_lookup(ratio: float) -> SmithReading:
    """Inverse of Smith's charts. ``ratio`` must be below :data:`SMITH_RATIO_MAX`;
    at or below :data:`SMITH_RATIO_MIN` the reading is the first-order limit."""
    if not ratio < SMITH_RATIO_MAX:
        raise ValueError(f"t20/t60 = {ratio:.4f} >= {SMITH_RATIO_MAX:.4f}: off Smith's chart")
    if ratio <= SMITH_RATIO_MIN:
        return SmithReading(ratio, math.inf, math.inf, 0.0, first_order=True)
    if ratio <= SMITH_RATIO_CRITICAL:
        r = float(brentq(lambda x: _ratio_lags(x) - ratio, 0.0, 1.0, xtol=_XTOL))
        zeta = (1.0 + r) / (2.0 * math.sqrt(r))
        return SmithReading(ratio, zeta, smith_times_lags(r)[1], r)
    zeta = float(brentq(lambda z: _ratio_zeta(z) - ratio, 0.0, 1.0, xtol=_XTOL))
    return SmithReading(ratio, zeta, smith_times_underdamped(zeta)[1],
                        1.0 if zeta == 1.0 else None)


@cache
def smith_curves(n: int = 400, zeta_max: float = 10.0) -> tuple[np.ndarray, np.ndarray,
                                                                   np.ndarray]:
    """Dense Smith charts ``(zeta, t20/t60, t60/tau)`` for drawing (read-only arrays)."""
    zeta = np.concatenate([np.linspace(0.0, 1.0, n // 2, endpoint=False),
                           np.geomspace(1.0, zeta_max, n - n // 2)])
    ratio = np.array([smith_ratio(z) for z in zeta])
    t60 = np.array([math.acos(0.4) if z == 0 else smith_t60_over_tau(z) for z in zeta])
    return _frozen(zeta), _frozen(ratio), _frozen(t60)


# =====================================================================================
# Strejc Table 2 (seed 002 eqs 16-18; ERRATA [S2] 15, 16, 17)
# =====================================================================================

#: eq. (16): ``T1 + T2 = t72 / 1.2564``; eq. (17): ``t2 = 0.3574 (T1 + T2)``.
STREJC_LEVEL_SUM = 0.72
STREJC_X72 = 1.2564
STREJC_READ_AT = 0.3574
#: Table 2 endpoints: ``y(0.3574 S)`` for ``r = 0`` (0.3005) and ``r = 1`` (0.1610).
STREJC_Y_MAX = -math.expm1(-STREJC_READ_AT)
STREJC_Y_MIN = float(gammainc(2.0, 2.0 * STREJC_READ_AT))


def strejc_y2(r: float) -> float:
    """Strejc's Table 2: ``y(0.3574 S)`` of ``1/((T1 s+1)(T2 s+1))``, ``r = T2/T1`` in [0, 1],
    ``S = T1 + T2`` (so ``T1 = S/(1+r)``, ``T2 = r S/(1+r)``)."""
    r = _tiny_to_zero(float(np.clip(r, 0.0, 1.0)))
    return _lags(STREJC_READ_AT, 1.0 / (1.0 + r), r / (1.0 + r))


def strejc_ratio(y2: float) -> float:
    """Inverse of Table 2: ``r = T2/T1`` from ``y(t2)``; clipped to 0 above the range
    (a single lag) and to 1 below it (equal lags), ERRATA [S2] 15."""
    if y2 >= STREJC_Y_MAX:
        return 0.0
    if y2 <= STREJC_Y_MIN:
        return 1.0
    return float(brentq(lambda r: strejc_y2(r) - y2, 0.0, 1.0, xtol=_XTOL))


@cache
def strejc_table2(n: int = 501) -> tuple[np.ndarray, np.ndarray]:
    """Dense Table 2 ``(r = T2/T1, y(0.3574 S))`` for drawing (read-only arrays)."""
    r = np.linspace(0.0, 1.0, n)
    y = np.array([strejc_y2(v) for v in r])
    return _frozen(r), _frozen(y)


# =====================================================================================
# Printed tables kept as data
# =====================================================================================

#: Latzel's Table 1, seed 002 section 2.2, as printed: ``(mu_a, n, alpha10, alpha50,
#: alpha90)`` with ``mu_a = t10/t90`` of ``1/(s+1)^n`` and ``alpha_p = 1/x_p(n)``
#: (``x_p`` = the p-quantile time of 1/(s+1)^n, ERRATA [S2] 1). ERRATA [S2] 3: the n = 2.5
#: row's alpha10 is printed 1.245 (exact 1.2420, a copy slip of Viteckova's constant); as
#: ERRATA says, the printed table is the default. All other entries agree with
#: :func:`latzel_row_exact` to rounding (+-0.001).
LATZEL_TABLE: tuple[tuple[float, float, float, float, float], ...] = (
    (0.137, 2, 1.880, 0.596, 0.257),
    (0.174, 2.5, 1.245, 0.460, 0.216),
    (0.207, 3, 0.907, 0.374, 0.188),
    (0.261, 4, 0.573, 0.272, 0.150),
    (0.304, 5, 0.411, 0.214, 0.125),
    (0.340, 6, 0.317, 0.176, 0.108),
    (0.370, 7, 0.257, 0.150, 0.095),
    (0.396, 8, 0.215, 0.130, 0.085),
    (0.418, 9, 0.184, 0.115, 0.077),
    (0.438, 10, 0.161, 0.103, 0.070),
    (0.456, 11, 0.142, 0.094, 0.065),
    (0.472, 12, 0.128, 0.086, 0.060),
    (0.486, 13, 0.116, 0.079, 0.056),
    (0.499, 14, 0.106, 0.073, 0.053),
    (0.512, 15, 0.097, 0.068, 0.050),
    (0.523, 16, 0.090, 0.064, 0.047),
    (0.533, 17, 0.084, 0.060, 0.045),
    (0.543, 18, 0.078, 0.057, 0.042),
    (0.552, 19, 0.073, 0.054, 0.040),
    (0.561, 20, 0.069, 0.051, 0.039),
)


def latzel_row_exact(n: float) -> tuple[float, float, float, float, float]:
    """Exact Table 1 row for order ``n``: ``(t10/t90, n, 1/x10, 1/x50, 1/x90)`` from the
    quantiles of the gamma distribution (``x_p = gammaincinv(n, p)``)."""
    x10, x50, x90 = (float(gammaincinv(n, p)) for p in (0.1, 0.5, 0.9))
    return x10 / x90, float(n), 1.0 / x10, 1.0 / x50, 1.0 / x90


#: Strejc's Table 3, seed 002 section 2.5 b), as printed: ``(n, Tu/Tn, y_i)``.
#: ERRATA [S2] 18: y_i(3) = 0.327 and y_i(4) = 0.359 are misprints (exact 0.3233 and
#: 0.3528; the same wrong pair is found in other course code, i.e. a common printed
#: source). Choice: the method uses the *exact* inflection ordinate
#: :func:`strejc_yi_exact` (ERRATA classes #18 as a typo with a definite fix, and the
#: other printed entries equal the exact ones to rounding, so nothing else changes),
#: while the order n is chosen on the *printed* Tu/Tn column (ERRATA [S2] 19: floor rule
#: with a 1e-3 tolerance, which exists because the printed entries are rounded, e.g.
#: 0.41 for the exact 0.4103).
STREJC_TABLE: tuple[tuple[int, float, float], ...] = (
    (2, 0.104, 0.264),
    (3, 0.218, 0.327),
    (4, 0.319, 0.359),
    (5, 0.41, 0.371),
    (6, 0.493, 0.384),
    (7, 0.57, 0.394),
    (8, 0.642, 0.401),
    (9, 0.709, 0.407),
    (10, 0.773, 0.413),
)


def strejc_yi_exact(n: int) -> float:
    """Fractional response of ``1/(s+1)^n`` at its inflection ``t = n - 1``:
    ``1 - e^{-(n-1)} sum_{k<n} (n-1)^k/k!`` (ERRATA [S2] 18)."""
    return float(gammainc(float(n), float(n - 1)))


def strejc_row_exact(n: int) -> tuple[int, float, float]:
    """Exact Table 3 row ``(n, Tu/Tn, y_i)`` of ``1/(Ts+1)^n`` (n >= 2): the inflection
    tangent at ``t_i = (n-1) T`` has slope ``m = (n-1)^{n-1} e^{-(n-1)}/((n-1)! T)``, so
    ``Tn = 1/m`` and ``Tu/Tn = m t_i - y_i``."""
    k = n - 1
    m = math.exp(k * math.log(k) - k - math.lgamma(n))
    yi = strejc_yi_exact(n)
    return n, m * k - yi, yi


def _frozen(a: np.ndarray) -> np.ndarray:
    a.setflags(write=False)
    return a
