"""Tuning rules against their published behaviour (Skogestad 2003; Grimholt & Skogestad
2018; Rivera, Morari & Skogestad 1986; Åström & Hägglund 2004) and the controller forms."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pipeline.models import ProcessModel
from pipeline.tuning import (
    Controller,
    nominal_margins,
    reduce,
    reduce_lags,
    tune_rule,
)

RATIOS = (0.1, 0.5, 1.0, 2.0, 4.0, 8.0, 20.0)  # tau/theta, the FOPDT sweep


def fopdt(ratio: float, K: float = 2.0, theta: float = 1.5) -> ProcessModel:
    return ProcessModel("first_order", {"K": K, "T": ratio * theta, "delay": theta})


# -- the half rule: Skogestad 2003's worked examples ---------------------------------------

def test_half_rule_example_e1_first_and_second_order():
    """1/((s+1)(0.2s+1)(0.04s+1)(0.008s+1)): tau1 = 1.1, theta = 0.148 (first order);
    tau1 = 1, tau2 = 0.22, theta = 0.028 (second order)."""
    first = reduce_lags(1.0, (1.0, 0.2, 0.04, 0.008))
    assert (first.kind, first.tau1, first.theta) == ("first_order", pytest.approx(1.1),
                                                     pytest.approx(0.148))
    second = reduce_lags(1.0, (1.0, 0.2, 0.04, 0.008), order=2)
    assert second.kind == "second_order"
    assert (second.tau1, second.tau2, second.theta) == (
        pytest.approx(1.0), pytest.approx(0.22), pytest.approx(0.028))


def test_half_rule_example_e4_zeros():
    """(-0.3s+1)(0.08s+1)/((2s+1)(s+1)(0.4s+1)(0.2s+1)(0.05s+1)^3): the zero 0.08 against
    the lag 0.2 (rule T3: a lag of 0.12), the inverse response as dead time: tau1 = 2.5,
    theta = 1.47 (first order); tau1 = 2, tau2 = 1.2, theta = 0.77 (second order)."""
    args = dict(zeros=(-0.3, 0.08))
    lags = (2.0, 1.0, 0.4, 0.2, 0.05, 0.05, 0.05)
    first = reduce_lags(1.0, lags, **args)
    assert (first.tau1, first.theta) == (pytest.approx(2.5), pytest.approx(1.47))
    second = reduce_lags(1.0, lags, order=2, **args)
    assert (second.tau1, second.tau2, second.theta) == (
        pytest.approx(2.0), pytest.approx(1.2), pytest.approx(0.77))


def test_reduction_of_every_structure():
    assert reduce(ProcessModel("two_lags", {"K": 3, "T1": 10, "T2": 2, "delay": 1})) \
        .tau1 == pytest.approx(11.0)
    nl = reduce(ProcessModel("n_lags", {"K": 1, "T": 2, "n": 3, "delay": 0.5}))
    assert (nl.tau1, nl.theta) == (pytest.approx(3.0), pytest.approx(0.5 + 1 + 2))
    # continuous in n across an integer
    a = reduce(ProcessModel("n_lags", {"K": 1, "T": 2, "n": 2.999999, "delay": 0}))
    b = reduce(ProcessModel("n_lags", {"K": 1, "T": 2, "n": 3.0, "delay": 0}))
    assert a.tau1 + a.theta == pytest.approx(b.tau1 + b.theta, rel=1e-5)
    inv = reduce(ProcessModel("zero_two_lags", {"K": 1, "Tz": -2, "T1": 8, "T2": 1,
                                                "delay": 0.5}))
    assert (inv.tau1, inv.theta) == (pytest.approx(8.5), pytest.approx(0.5 + 2 + 0.5))
    il = reduce(ProcessModel("integrator_lag", {"K": 0.1, "T": 4, "delay": 1}))
    assert (il.kind, il.theta) == ("integrator", pytest.approx(3.0))
    il2 = reduce(ProcessModel("integrator_lag", {"K": 0.1, "T": 4, "delay": 1}), 2)
    assert (il2.kind, il2.tau1, il2.theta) == ("integrator_lag", 4.0, 1.0)
    osc = reduce(ProcessModel("second_order", {"K": 1, "zeta": 0.4, "wn": 0.5,
                                               "delay": 1}), 2)
    assert (osc.kind, osc.tau1, osc.zeta) == ("oscillating", pytest.approx(2.0), 0.4)
    # the sample period adds half of itself to the dead time
    h = reduce(ProcessModel("first_order", {"K": 1, "T": 5, "delay": 1}), sample_time=0.4)
    assert h.theta == pytest.approx(1.2)


# -- SIMC ---------------------------------------------------------------------------------

def test_simc_formulas_first_order_and_integrating():
    s = tune_rule(fopdt(8.0, K=2.0, theta=1.0), "simc").controller
    # Kc = tau1/(k (tau_c + theta)) = 8/(2*2), Ti = min(8, 4*2) = 8
    assert (s.kind, s.Kc, s.Ti) == ("PI", pytest.approx(2.0), pytest.approx(8.0))
    s20 = tune_rule(fopdt(20.0, K=2.0, theta=1.0), "simc").controller
    assert s20.Ti == pytest.approx(8.0)  # 4 (tau_c + theta) caps the integral time
    i = tune_rule(ProcessModel("integrator", {"K": 0.5, "delay": 2.0}), "simc").controller
    assert (i.Kc, i.Ti) == (pytest.approx(1 / (0.5 * 4)), pytest.approx(16.0))
    p = tune_rule(fopdt(8.0, K=2.0, theta=1.0), "simc", "P").controller
    assert (p.kind, p.Kc, p.Ti) == ("P", pytest.approx(2.0), math.inf)


def test_simc_second_order_series_pid_converted_exactly():
    """Series SIMC PID (Skogestad 2003, eq. (29)) with the derivative filter counted in
    the dead time: the settings are eq. (29) at theta + Tf, Tf = Td/10 of the ideal form
    (3.8) they give (a fixed point), and the series form converts back exactly."""
    m = ProcessModel("two_lags", {"K": 1.0, "T1": 10.0, "T2": 4.0, "delay": 1.0})
    st = tune_rule(m, "simc")
    c = st.controller
    assert c.kind == "PID" and st.rule_form == "series"
    theta = 1.0 + c.Tf
    # series Kc' = 10/(2 theta), Ti' = min(10, 8 theta), Td' = 4 -> ideal (3.8)
    kc_s, ti_s = 10.0 / (2.0 * theta), min(10.0, 8.0 * theta)
    assert c.Kc == pytest.approx(kc_s * (1 + 4 / ti_s))
    assert c.Ti == pytest.approx(ti_s + 4.0)
    assert c.Td == pytest.approx(ti_s * 4 / (ti_s + 4.0))
    assert c.Tf == pytest.approx(c.Td / 10.0)
    assert st.tau_c == pytest.approx(theta)
    assert any("derivative filter" in n for n in st.notes)
    srs = c.as_series()
    assert (srs["Kc"], srs["Ti"], srs["Td"]) == (pytest.approx(kc_s), pytest.approx(ti_s),
                                                 pytest.approx(4.0))


@pytest.mark.parametrize("tau", [2.0, 5.0, 10.0])
def test_simc_pid_keeps_its_robustness_with_the_derivative_filter(tau):
    """On ``e^(-s)/(tau s+1)^2`` SIMC's PID, filter included, has Ms in SIMC's 1.55-1.75
    (Skogestad 2003, Section 5: Ms about 1.6 with tau_c = theta); with the filter left
    out of the dead time, Ms 1.87 at tau = 5 (the benchmark plant P5 of Åström &
    Hägglund 2000) - the reason it is counted."""
    m = ProcessModel("two_lags", {"K": 1.0, "T1": tau, "T2": tau, "delay": 1.0})
    c = tune_rule(m, "simc").controller
    assert c.kind == "PID"
    assert 1.55 <= nominal_margins(m, c).ms <= 1.75
    if tau == 5.0:
        naive = Controller.series(tau / 2.0, tau, tau)
        assert nominal_margins(m, naive).ms == pytest.approx(1.87, abs=0.01)


@pytest.mark.parametrize("zeta", (0.05, 0.1, 0.2, 0.4))
def test_simc_oscillating_pid_keeps_its_zeros_on_the_poles(zeta):
    """Skogestad 2003 eq. (35): Ti = 2 zeta tau0, Td = tau0/(2 zeta) cancel the pair and
    leave e^(-theta s)/((tau_c + theta) s), Ms 1.59 unfiltered. The derivative filter is
    Ti/N when Ti < Td (issue 28): Td/N was slower than Ti for zeta < 0.16 and gave Ms 115
    (zeta 0.05, no dead time), 11.5 (zeta 0.1, theta 0.05 tau0), 7.8 (zeta 0.1, theta 0.5
    tau0) on the model itself."""
    for theta in (0.0, 0.1, 1.0, 2.0):  # tau0 = 2
        m = ProcessModel("second_order", {"K": 2.0, "zeta": zeta, "wn": 0.5, "delay": theta})
        c = tune_rule(m, "simc").controller
        assert c.kind == "PID"
        assert (c.Ti, c.Td) == (pytest.approx(4 * zeta), pytest.approx(1 / zeta))
        assert c.Tf == pytest.approx(c.Ti / 10)
        mg = nominal_margins(m, c)
        # a dead time shorter than the filter's lag still costs robustness (2.7 at zeta 0.4)
        assert mg.stable and mg.ms < (1.9 if theta != 0.1 else 2.8), (theta, mg.ms)


@pytest.mark.parametrize("ratio", RATIOS)
def test_simc_tight_ms_and_gain_margin_on_the_fopdt_sweep(ratio):
    """Skogestad 2003 (Table 3): tau_c = theta gives Ms 1.59-1.70 and GM 2.96-3.14."""
    m = fopdt(ratio)
    mg = nominal_margins(m, tune_rule(m, "simc", "PI").controller)
    assert mg.stable
    assert 1.55 <= mg.ms <= 1.75
    assert 2.9 <= mg.gain_margin <= 3.2


def test_simc_integrating_with_delay():
    """k e^(-theta s)/s with tau_c = theta: Ms 1.70, GM 2.96, PM 46.9 deg (Skogestad
    2003, Table 3)."""
    m = ProcessModel("integrator", {"K": 0.3, "delay": 2.0})
    mg = nominal_margins(m, tune_rule(m, "simc").controller)
    assert mg.ms == pytest.approx(1.70, rel=0.02)
    assert mg.gain_margin == pytest.approx(2.96, rel=0.02)
    assert mg.phase_margin == pytest.approx(46.9, rel=0.02)


@pytest.mark.parametrize("ratio", RATIOS)
def test_amigo_pi_ms_at_most_1_5(ratio):
    """AMIGO was designed for Ms = 1.4 (Åström & Hägglund 2004); at most 1.5 here."""
    m = fopdt(ratio)
    mg = nominal_margins(m, tune_rule(m, "amigo").controller)
    assert mg.stable and mg.ms <= 1.5


def test_amigo_formulas():
    c = tune_rule(fopdt(1.0, K=1.0, theta=1.0), "amigo").controller
    # L = T = 1: Kc = 0.15 + (0.35 - 1/4) = 0.25, Ti = 0.35 + 13/20 = 1.0
    assert (c.Kc, c.Ti) == (pytest.approx(0.25), pytest.approx(1.0))
    d = tune_rule(fopdt(1.0, K=1.0, theta=1.0), "amigo", "PID").controller
    assert (d.Kc, d.Ti, d.Td) == (pytest.approx(0.65), pytest.approx(1.2 / 1.1),
                                  pytest.approx(0.5 / 1.3))
    with pytest.raises(ValueError, match="dead time"):
        tune_rule(ProcessModel("first_order", {"K": 1, "T": 1, "delay": 0}), "amigo")


def test_improved_simc_pid_on_a_delay_dominant_process():
    """Improved SIMC adds Td = theta/3 (series): on tau/theta = 0.1 the ideal settings
    follow from eq. (3.8), and the loop is more robust than Ms 1.6."""
    m = fopdt(0.1, K=1.0, theta=1.0)
    st = tune_rule(m, "simc_improved")
    c = st.controller
    kc_s, ti_s, td_s = 0.1 / 2.0, 0.1, 1.0 / 3.0
    assert c.Kc == pytest.approx(kc_s * (1 + td_s / ti_s))
    assert c.Ti == pytest.approx(ti_s + td_s)
    assert nominal_margins(m, c).ms < 1.6
    pi = tune_rule(m, "simc_improved", "PI").controller
    assert pi.Ti == pytest.approx(0.1 + 1 / 3)  # tau1 + theta/3


def test_lambda_rules():
    m = fopdt(4.0, K=2.0, theta=1.0)
    c = tune_rule(m, "lambda").controller  # lambda = tau1 = 4
    assert (c.Kc, c.Ti) == (pytest.approx(4 / (2 * 5)), pytest.approx(4.0))
    d = tune_rule(m, "lambda", "PID", tau_c=1.0).controller
    assert d.Kc == pytest.approx(9 / (2 * 3))
    assert (d.Ti, d.Td) == (pytest.approx(4.5), pytest.approx(4 / 9))
    i = tune_rule(ProcessModel("integrator", {"K": 0.5, "delay": 1.0}), "lambda").controller
    assert (i.Kc, i.Ti) == (pytest.approx(7 / (0.5 * 16)), pytest.approx(7.0))


def test_tau_c_smooth_is_more_robust_and_no_delay_has_a_floor():
    m = fopdt(4.0)
    tight = nominal_margins(m, tune_rule(m, "simc", tau_c="tight").controller).ms
    smooth = nominal_margins(m, tune_rule(m, "simc", tau_c="smooth").controller).ms
    assert smooth < tight
    st = tune_rule(ProcessModel("first_order", {"K": 1, "T": 10, "delay": 0}), "simc")
    assert st.tau_c == pytest.approx(1.0) and st.notes
    with pytest.raises(ValueError):
        tune_rule(m, "simc", tau_c=-1.0)


def test_controller_forms_round_trip():
    c = Controller.ideal(2.0, 10.0, 1.0)
    assert c.Tf == pytest.approx(0.1)
    p = c.parallel()
    assert (p["Kp"], p["Ki"], p["Kd"]) == (2.0, pytest.approx(0.2), pytest.approx(2.0))
    srs = c.as_series()
    back = Controller.series(srs["Kc"], srs["Ti"], srs["Td"])
    assert (back.Kc, back.Ti, back.Td) == (pytest.approx(2.0), pytest.approx(10.0),
                                           pytest.approx(1.0))
    assert Controller.ideal(1.0, 2.0, 1.0).as_series() is None  # Ti < 4 Td
    s = np.array([0.3j, 1 + 2j])
    num, den = c.num_den()
    assert np.allclose(np.polyval(num, s) / np.polyval(den, s), c.response(s))
