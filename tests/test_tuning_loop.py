"""The simulated loop (pipeline.tuning.loop) against known truth: closed-form closed loops
(P and pole-cancelling PI on a first-order plant), and python-control references with a
10th-order Padé dead time for the delayed loops (IAE within 2 %)."""

from __future__ import annotations

import math

import control
import numpy as np
import pytest

from pipeline.tuning.loop import LoopResponse, Pid, simulate_loop


def _reference(num, den, delay: float, pid: Pid, res: LoopResponse) -> tuple[np.ndarray, int]:
    """The continuous loop on ``res``'s grid (the same r_step, d_step and t_load), by
    superposition of two exact step responses; the dead time by ``control.pade(delay,
    10)``. Returns y and the load's first sample."""
    s = control.tf("s")
    g = control.ss(control.tf(num, den))
    if delay > 0:
        g = g * control.ss(control.tf(*control.pade(delay, 10)))
    integ = 1 / (pid.Ti * s) if math.isfinite(pid.Ti) else 0 * s
    c_y = pid.Kc * (1 + integ)
    if pid.Td > 0:
        c_y = c_y + pid.Kc * pid.Td * s / (pid.Tf * s + 1)
    c_r = pid.Kc * (pid.b + integ)
    y_d = control.feedback(g, control.ss(c_y))  # y/d = G/(1 + G C_y)
    y_r = y_d * control.ss(c_r)  # y/r = G C_r/(1 + G C_y)
    k = int(np.argmax(res.d != 0))
    y = res.r[-1] * np.ravel(control.step_response(y_r, T=res.t).outputs)
    y[k:] += res.d[-1] * np.ravel(control.step_response(y_d, T=res.t[k:] - res.t[k]).outputs)
    return y, k


def _iae(t: np.ndarray, e: np.ndarray) -> float:
    return float(np.trapezoid(np.abs(e), t))


def _assert_iae_matches(res: LoopResponse, y_ref: np.ndarray, k: int, rel: float = 0.02):
    assert res.setpoint.iae == pytest.approx(_iae(res.t[:k], res.r[:k] - y_ref[:k]), rel=rel)
    assert res.load.iae == pytest.approx(_iae(res.t[k:], res.r[k:] - y_ref[k:]), rel=rel)


def _first_crossing(t: np.ndarray, y: np.ndarray, level: float) -> float:
    i = int(np.argmax(y >= level))
    return float(t[i - 1] + (t[i] - t[i - 1]) * (level - y[i - 1]) / (y[i] - y[i - 1]))


def test_p_control_of_a_first_order_plant():
    K, T, Kc = 2.0, 5.0, 2.0  # Kc K = 4: offset 1/5, closed-loop time constant T/5 = 1 s
    res = simulate_loop([K], [T, 1.0], 0.0, Pid(Kc=Kc))
    k = int(np.argmax(res.d != 0))
    y_ss = Kc * K / (1 + Kc * K)
    assert res.y[k] == pytest.approx(y_ss, abs=1e-3)
    tau = _first_crossing(res.t, res.y, y_ss * (1 - math.exp(-1)))
    assert tau == pytest.approx(T / (1 + Kc * K), rel=0.01)
    # the offset never enters the 2 % band around r: no settling, by definition
    assert res.setpoint.settling_time == math.inf
    assert res.setpoint.overshoot == pytest.approx(0.0, abs=1e-9)
    assert not res.setpoint.saturated and not res.load.saturated
    assert res.setpoint.u_peak == pytest.approx(Kc * 1.0)  # the proportional kick at t = 0


def test_pi_cancelling_the_pole_is_a_first_order_loop():
    K, T, Kc = 2.0, 5.0, 1.5  # Ti = T: L = Kc K/(T s), closed loop 1/(T/(Kc K) s + 1)
    # the sampled controller's hold lags by dt/2: dt = 1 ms keeps that below 1e-3 of the step
    res = simulate_loop([K], [T, 1.0], 0.0, Pid(Kc=Kc, Ti=T), t_load=15.0, t_end=20.0,
                        dt=1e-3)
    ph = res.t < 15.0 - 1e-9
    exact = 1.0 - np.exp(-res.t[ph] * Kc * K / T)
    assert np.max(np.abs(res.y[ph] - exact)) < 1e-3
    assert res.setpoint.iae == pytest.approx(T / (Kc * K), rel=2e-3)
    # the load brings the cancelled lag back: y - r = d (exp(-t/T) - exp(-t Kc K/T)) here
    # (K/T/(Kc K/T - 1/T) = 1 for these numbers; Skogestad 2003's case for Ti < T)
    tl = res.t[~ph] - 15.0
    load = res.d[-1] * (np.exp(-tl / T) - np.exp(-tl * Kc * K / T))
    assert np.max(np.abs(res.y[~ph] - res.r[~ph] - load)) < 1e-3


def test_fopdt_with_simc_pi_against_pade_reference():
    K, T, theta = 2.0, 10.0, 1.0
    tau_c = theta
    pid = Pid(Kc=T / (K * (tau_c + theta)), Ti=min(T, 4 * (tau_c + theta)))
    res = simulate_loop([K], [T, 1.0], theta, pid)
    assert np.all(res.y[res.t <= theta + 1e-12] == 0.0)  # the exact dead time
    assert res.y[np.argmax(res.t > theta + 1e-12)] > 0.0
    y_ref, k = _reference([K], [T, 1.0], theta, pid, res)
    _assert_iae_matches(res, y_ref, k)
    # overshoot of the reference 0.0812, here 0.0828 (the hold's dt/2 lag adds a little)
    over_ref = max(0.0, float(np.max(y_ref[:k] - y_ref[k - 1]))) / res.r[-1]
    assert res.setpoint.overshoot == pytest.approx(over_ref, abs=0.005)
    assert 0.05 < res.setpoint.overshoot < 0.12
    # the load phase: integral of e = d Ti/Kc with the default d_step = r_step/K
    assert res.d[-1] == pytest.approx(1.0 / K)
    assert res.load.iae == pytest.approx(res.d[-1] * pid.Ti / pid.Kc, rel=1e-3)
    assert math.isfinite(res.setpoint.settling_time) and math.isfinite(res.load.settling_time)


def test_integrating_plant_with_simc_pi():
    k_v, theta = 0.5, 1.0
    tau_c = theta
    pid = Pid(Kc=1 / (k_v * (tau_c + theta)), Ti=4 * (tau_c + theta))
    res = simulate_loop([k_v], [1.0, 0.0], theta, pid)
    # the integral removes the load's offset
    assert abs(res.y[-1] - res.r[-1]) < 1e-3 * res.load.peak_deviation
    y_ref, k = _reference([k_v], [1.0, 0.0], theta, pid, res)
    _assert_iae_matches(res, y_ref, k)
    assert math.isfinite(res.load.settling_time)  # against 2 % of the peak deviation
    # any PI: the integral of e over the load's recovery is d Ti/Kc; e keeps its sign here
    assert res.load.iae == pytest.approx(res.d[-1] * pid.Ti / pid.Kc, rel=1e-3)
    assert res.load.overshoot == pytest.approx(0.0, abs=1e-9)


def test_back_calculation_prevents_windup():
    K, T, theta = 1.0, 10.0, 1.0
    tau_c = 0.5 * theta  # aggressive: Kc = 6.7 kicks u far beyond the limits
    pid = Pid(Kc=T / (K * (tau_c + theta)), Ti=min(T, 4 * (tau_c + theta)))
    lim = (-1.5, 1.5)  # the steady state needs u = 1
    linear = simulate_loop([K], [T, 1.0], theta, pid)
    guarded = simulate_loop([K], [T, 1.0], theta, pid, u_limits=lim)
    wound = simulate_loop([K], [T, 1.0], theta, pid, u_limits=lim, anti_windup=False)
    assert guarded.setpoint.saturated and wound.setpoint.saturated
    assert guarded.anti_windup and not wound.anti_windup
    assert np.all(guarded.u >= lim[0]) and np.all(guarded.u <= lim[1])
    # measured: linear 0.28, wound 0.35, guarded 0.0. Tracking (Tt = Ti/2) keeps the integral
    # near the steady-state u while saturated, so y approaches r as an open-loop step does
    assert wound.setpoint.overshoot > 2 * guarded.setpoint.overshoot
    assert wound.setpoint.overshoot > linear.setpoint.overshoot
    assert guarded.setpoint.overshoot < 0.02
    assert guarded.setpoint.settling_time < 0.6 * wound.setpoint.settling_time
    assert abs(guarded.y[-1] - 1.0) < 1e-3 and abs(wound.y[-1] - 1.0) < 1e-3


@pytest.mark.parametrize("b", [1.0, 0.5])
def test_pid_with_derivative_filter_against_pade_reference(b):
    # SIMC PID (series form Kc = 5, Ti = 8, Td = 2) in the ideal form, Tf = Td/10
    den = np.polymul([10.0, 1.0], [2.0, 1.0])
    Td = 8 * 2 / 10
    pid = Pid(Kc=5 * (1 + 2 / 8), Ti=10.0, Td=Td, Tf=Td / 10, b=b)
    res = simulate_loop([1.0], den, 1.0, pid)
    y_ref, k = _reference([1.0], den, 1.0, pid, res)
    _assert_iae_matches(res, y_ref, k)
    assert np.max(np.abs(res.y - y_ref)) < 0.01


def test_lead_lag_plant_steady_state():
    K, Tz, T = 2.0, 3.0, 5.0  # the feedthrough K Tz/T closes an algebraic loop (no delay)
    p_only = simulate_loop([K * Tz, K], [T, 1.0], 0.0, Pid(Kc=0.5))
    k = int(np.argmax(p_only.d != 0))  # y[k] already has the load (feedthrough)
    assert p_only.y[k - 1] == pytest.approx(0.5 * K / (1 + 0.5 * K), abs=1e-4)
    # y jumps at t = 0: y = D Kc (r - y) with D = K Tz/T
    D = K * Tz / T
    assert p_only.y[0] == pytest.approx(D * 0.5 / (1 + D * 0.5), rel=1e-12)
    pid = Pid(Kc=0.5, Ti=5.0)
    for delay in (0.0, 0.5):
        res = simulate_loop([K * Tz, K], [T, 1.0], delay, pid)
        k = int(np.argmax(res.d != 0))
        assert not res.setpoint.saturated and not res.load.saturated
        assert res.y[k - 1] == pytest.approx(1.0, abs=1e-3)
        assert res.y[-1] == pytest.approx(1.0, abs=1e-3)
    y_ref, k = _reference([K * Tz, K], [T, 1.0], 0.0, pid,
                          res := simulate_loop([K * Tz, K], [T, 1.0], 0.0, pid))
    _assert_iae_matches(res, y_ref, k)
    # saturated through the feedthrough: the limiter holds and the loop still settles
    # (Kc = 2: u(0) = Kc/(1 + D Kc) = 0.59 > 0.55 > the steady u = 1/K)
    sat = simulate_loop([K * Tz, K], [T, 1.0], 0.0, Pid(Kc=2.0, Ti=5.0), u_limits=(-1, 0.55))
    assert sat.setpoint.saturated and sat.u[0] == 0.55
    assert sat.y[0] == pytest.approx(D * 0.55)  # y = D sat(v) at t = 0
    assert sat.y[-1] == pytest.approx(1.0, abs=1e-3)


def test_invalid_inputs_are_refused():
    with pytest.raises(ValueError):
        Pid(Kc=1.0, Ti=5.0, Td=1.0)  # a derivative needs a filter
    with pytest.raises(ValueError):
        Pid(Kc=1.0, Ti=0.0)
    with pytest.raises(ValueError):
        simulate_loop([1.0], [1.0, 1.0], 1.0, Pid(Kc=1.0), dt=0.3)  # 1/0.3 not whole
    with pytest.raises(ValueError):
        simulate_loop([1.0, 0.0, 0.0], [1.0, 1.0], 0.0, Pid(Kc=1.0))  # improper
    with pytest.raises(ValueError):
        simulate_loop([1.0], [1.0, 1.0], 0.0, Pid(Kc=1.0), u_limits=(0.5, 1.0))


def test_a_dead_time_far_below_the_loop_time_scale_stays_bounded():
    # 1e-6 s of dead time on a 10 s lag: dividing it into whole samples would need 10^8
    # samples (this ran a test machine out of memory); it is rounded to whole samples
    tiny = simulate_loop([1.0], [10.0, 1.0], 1e-6, Pid(Kc=2.0, Ti=10.0))
    assert tiny.t.size <= 400_001
    # Ti = T cancels the lag: the loop is 1/(T/(Kc K) s + 1), its setpoint IAE T/(Kc K)
    assert tiny.setpoint.iae == pytest.approx(10.0 / 2.0, rel=1e-3)
