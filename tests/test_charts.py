"""The computed charts of seed 002 against values derived independently.

Closed forms (first-order limits, gamma quantiles via scipy.special), scipy.signal
simulations of the transfer functions, and the values quoted in ERRATA [S2] 7, 10, 13,
15, 18.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import signal
from scipy.special import gammainc, gammaincinv

from pipeline.methods import charts


def crossing(t: np.ndarray, y: np.ndarray, level: float) -> float:
    i = int(np.argmax(y >= level))
    return float(t[i - 1] + (level - y[i - 1]) * (t[i] - t[i - 1]) / (y[i] - y[i - 1]))


# -- Harriott (Fig. 4) -------------------------------------------------------------------


def test_harriott_range_endpoints() -> None:
    assert charts.harriott_y(0.0) == pytest.approx(1 - math.exp(-0.5), abs=1e-12)
    assert charts.harriott_y(0.5) == pytest.approx(1 - 2 / math.e, abs=1e-12)
    # the paper's 0.26 ... 0.39 is the exact range rounded (ERRATA [S2] 7)
    assert round(charts.HARRIOTT_Y_MIN, 4) == 0.2642
    assert round(charts.HARRIOTT_Y_MAX, 4) == 0.3935


def test_harriott_curve_is_decreasing_and_matches_scipy() -> None:
    r, y = charts.harriott_curve()
    assert np.all(np.diff(y) < 0)
    for rv in (0.1, 0.3):  # independent: simulate 1/((r s+1)((1-r) s+1)) at t = 0.5
        t = np.linspace(0, 0.5, 5001)
        _, ys = signal.step(signal.lti([1.0], np.polymul([rv, 1.0], [1 - rv, 1.0])), T=t)
        assert charts.harriott_y(rv) == pytest.approx(ys[-1], abs=1e-6)


def test_harriott_curves_cross_73_percent_near_1_3() -> None:
    """ERRATA [S2] 10: exact x73 = 1.3093 (r = 0), 1.2778 (0.25), 1.2933 (0.5)."""
    assert charts.harriott_x73(0.0) == pytest.approx(-math.log(0.27), abs=1e-9)
    assert charts.harriott_x73(0.5) == pytest.approx(gammaincinv(2, 0.73) / 2, abs=1e-9)
    assert round(charts.harriott_x73(0.0), 4) == 1.3093
    assert round(charts.harriott_x73(0.25), 4) == 1.2778
    assert round(charts.harriott_x73(0.5), 4) == 1.2933
    for r in np.linspace(0, 0.5, 11):
        assert abs(charts.harriott_x73(r) - 1.3) < 0.025


def test_harriott_inverse_clips_outside() -> None:
    assert charts.harriott_r(0.40) == 0.0
    assert charts.harriott_r(0.25) == 0.5
    # flat end: still inverted to the right r (root finding, not a digitised table)
    assert charts.harriott_r(charts.harriott_y(0.49)) == pytest.approx(0.49, abs=1e-6)


# -- Smith (Fig. 6) ----------------------------------------------------------------------


def test_smith_ratio_limits() -> None:
    """0.5551 at zeta -> 0 (1 - cos t) and 0.2435 at zeta -> inf (first-order lag)."""
    assert charts.SMITH_RATIO_MAX == pytest.approx(math.acos(0.8) / math.acos(0.4))
    assert charts.SMITH_RATIO_MIN == pytest.approx(math.log(1.25) / math.log(2.5))
    assert round(charts.SMITH_RATIO_MAX, 4) == 0.5551
    assert round(charts.SMITH_RATIO_MIN, 4) == 0.2435
    assert charts.smith_ratio(1e-6) == pytest.approx(0.5551, abs=1e-4)
    assert charts.smith_ratio(1e4) == pytest.approx(0.2435, abs=1e-4)


def test_smith_curves_are_monotone() -> None:
    zeta, ratio, t60 = charts.smith_curves()
    assert np.all(np.diff(ratio) < 0)
    assert np.all(np.diff(t60) > 0)
    assert t60[0] == pytest.approx(math.acos(0.4))


@pytest.mark.parametrize("zeta", [0.3, 0.7, 1.0, 2.0, 5.0])
def test_smith_against_scipy_simulation(zeta: float) -> None:
    """Independent route: simulate 1/(s^2 + 2 zeta s + 1) and read t20, t60."""
    t = np.linspace(0, 20, 20001)
    _, y = signal.step(signal.lti([1.0], [1.0, 2 * zeta, 1.0]), T=t)
    t20, t60 = crossing(t, y, 0.2), crossing(t, y, 0.6)
    assert charts.smith_ratio(zeta) == pytest.approx(t20 / t60, abs=1e-5)
    assert charts.smith_t60_over_tau(zeta) == pytest.approx(t60, rel=1e-5)
    rd = charts.smith_lookup(t20 / t60)
    assert rd.zeta == pytest.approx(zeta, rel=1e-3)
    assert rd.t60_over_tau == pytest.approx(t60, rel=1e-4)
    if zeta > 1:  # at zeta = 1 the split is ill-conditioned (ERRATA [S2] 27)
        assert rd.lag_ratio == pytest.approx(
            (zeta - math.sqrt(zeta**2 - 1)) / (zeta + math.sqrt(zeta**2 - 1)), rel=1e-3)


def test_smith_critical_ratio_and_domain() -> None:
    assert charts.SMITH_RATIO_CRITICAL == pytest.approx(
        gammaincinv(2, 0.2) / gammaincinv(2, 0.6), abs=1e-12)
    assert charts.smith_lookup(0.2).first_order
    with pytest.raises(ValueError):
        charts.smith_lookup(0.56)


# -- Strejc Table 2 ----------------------------------------------------------------------


def test_strejc_table2_endpoints_and_erratum_point() -> None:
    """ERRATA [S2] 15: 0.3005 (r = 0), 0.1610 (r = 1), 0.264 at y = 0.20, 0.538 at 0.17."""
    assert charts.strejc_y2(0.0) == pytest.approx(1 - math.exp(-0.3574), abs=1e-12)
    assert charts.strejc_y2(1.0) == pytest.approx(gammainc(2, 0.7148), abs=1e-12)
    assert round(charts.strejc_y2(0.0), 4) == 0.3005
    assert round(charts.strejc_y2(1.0), 4) == 0.1610
    assert round(charts.strejc_ratio(0.20), 3) == 0.264
    assert round(charts.strejc_ratio(0.17), 3) == 0.538
    assert charts.strejc_ratio(0.31) == 0.0 and charts.strejc_ratio(0.15) == 1.0
    r, y = charts.strejc_table2()
    assert np.all(np.diff(y) < 0)


def test_strejc_table2_against_two_lag_formula() -> None:
    """y(0.3574 S) written out: 1 - (T1 e^{-t/T1} - T2 e^{-t/T2})/(T1 - T2)."""
    for r in (0.1, 0.5, 0.8):
        T1, T2 = 1 / (1 + r), r / (1 + r)
        t = 0.3574
        y = 1 - (T1 * math.exp(-t / T1) - T2 * math.exp(-t / T2)) / (T1 - T2)
        assert charts.strejc_y2(r) == pytest.approx(y, abs=1e-12)


# -- chart round trips (property-based) ---------------------------------------------------


@settings(max_examples=40, deadline=None)
@given(st.floats(0.0, 0.5))
def test_harriott_round_trip(r: float) -> None:
    back = charts.harriott_r(charts.harriott_y(r))
    assert charts.harriott_y(back) == pytest.approx(charts.harriott_y(r), abs=1e-12)
    assert back == pytest.approx(r, abs=1e-5)  # the chart is flat (dy/dr -> 0) at r = 0.5


@settings(max_examples=40, deadline=None)
@given(st.floats(0.0, 1.0))
def test_strejc_round_trip(r: float) -> None:
    back = charts.strejc_ratio(charts.strejc_y2(r))
    assert charts.strejc_y2(back) == pytest.approx(charts.strejc_y2(r), abs=1e-12)
    assert back == pytest.approx(r, abs=1e-5)  # flat at r = 1 (T1 <-> T2 symmetry)


@settings(max_examples=25, deadline=None)
@given(st.floats(0.25, 0.55))
def test_smith_round_trip(ratio: float) -> None:
    rd = charts.smith_lookup(ratio)
    assert charts.smith_ratio(rd.zeta) == pytest.approx(ratio, abs=1e-9)


# -- printed tables ------------------------------------------------------------------------


@pytest.mark.parametrize("row", charts.LATZEL_TABLE, ids=lambda r: f"n{r[1]}")
def test_latzel_table_is_gamma_quantiles(row: tuple) -> None:
    """Tab. 1: alpha_p = 1/x_p(n), mu_a = x10/x90 (x_p = gammaincinv(n, p)); the n = 2.5
    alpha10 is the printed 1.245 (exact 1.2420, ERRATA [S2] 3)."""
    mu_a, n, *alphas = row
    x = [gammaincinv(n, p) for p in (0.1, 0.5, 0.9)]
    assert mu_a == pytest.approx(x[0] / x[2], abs=0.001)
    for p, (a, xp) in zip((10, 50, 90), zip(alphas, x, strict=True), strict=True):
        if n == 2.5 and p == 10:
            assert a - 1 / xp == pytest.approx(0.003, abs=0.0005)
        else:
            assert a == pytest.approx(1 / xp, abs=0.002)


def test_strejc_table3_against_inflection_of_n_lags() -> None:
    """Tab. 3 Tu/Tn and y_i from a numerical tangent on a dense (s+1)^n response;
    the printed y_i for n = 3, 4 are the misprints of ERRATA [S2] 18."""
    t = np.linspace(0, 40, 400001)
    for n, tu_tn, yi in charts.STREJC_TABLE:
        h = gammainc(n, t)
        d = np.gradient(h, t)
        j = int(np.argmax(d))
        ratio = d[j] * t[j] - h[j]
        assert charts.strejc_row_exact(n)[1] == pytest.approx(ratio, abs=1e-6)
        assert charts.strejc_yi_exact(n) == pytest.approx(h[j], abs=1e-6)
        assert tu_tn == pytest.approx(ratio, abs=0.001)
        if n in (3, 4):
            assert abs(yi - h[j]) > 0.003
        else:
            assert yi == pytest.approx(h[j], abs=0.001)
