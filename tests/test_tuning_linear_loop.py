"""The tuned loop simulated a dead time at a time (issue 30 item 5: a 100-sample log spent
0.26-0.35 s of its 1.9 s in the per-sample loop): the blocks give the per-sample
recursion's numbers to rounding on every kind of plant the tuner meets, without limits,
with limits that never bind, and with limits that bind (with and without anti-windup)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pipeline.tuning import loop
from pipeline.tuning.loop import Pid, simulate_loop

CASES = {
    "FOPDT PI": ([2.0], [10.0, 1.0], 2.0, Pid(Kc=2.5, Ti=10.0)),
    "two lags PID": ([1.5], [30.0, 13.0, 1.0], 1.0, Pid(Kc=3.0, Ti=12.0, Td=2.5, Tf=0.25)),
    "integrator lag PI": ([0.1], [5.0, 1.0, 0.0], 2.0, Pid(Kc=1.0, Ti=40.0)),
    "lead-lag, setpoint weight": ([1.2 * 9.0, 1.2], [6.0, 1.0], 0.9, Pid(Kc=0.5, Ti=6.0,
                                                                       b=0.5)),
    "underdamped P": ([1.0], [1.0, 0.6, 1.0], 0.5, Pid(Kc=0.8, Ti=math.inf)),
    "delay dominant": ([2.0], [10.0, 1.0], 30.0, Pid(Kc=0.15, Ti=10.0)),
    "inverse response": ([-1.0, 1.0], [20.0, 9.0, 1.0], 1.0, Pid(Kc=1.0, Ti=9.0)),
    "unstable first order": ([1.0], [5.0, -1.0], 0.5, Pid(Kc=3.0, Ti=4.0)),
    # higher orders (review: the plant as one expanded polynomial in lfilter lost 4 digits
    # at n = 4 and diverged from n = 5; the blocks are in state space)
    "three lags": ([1.0], np.poly([-0.1] * 3) * 1000.0, 1.0, Pid(Kc=1.0, Ti=25.0)),
    "four lags PID": ([1.0], np.poly([-0.1] * 4) * 1e4, 1.0,
                      Pid(Kc=1.2, Ti=30.0, Td=6.0, Tf=0.6)),
    "six lags": ([2.0], np.poly([-0.2] * 6) * 5.0**6, 0.5, Pid(Kc=0.3, Ti=20.0)),
    "eight lags": ([1.0], np.poly([-0.5] * 8) * 2.0**8, 1.0, Pid(Kc=0.25, Ti=12.0)),
    "lag behind a pair": ([1.0], np.polymul([8.0, 1.0], [1.0, 0.4, 1.0]), 0.8,
                          Pid(Kc=0.3, Ti=6.0)),
}


def _per_sample(monkeypatch, *args, **kwargs):
    with monkeypatch.context() as mp:
        mp.setattr(loop, "MIN_BLOCK", 10**9)
        return simulate_loop(*args, **kwargs)


def _limits(num, den, delay, pid, kind):
    """None, limits that never bind, or limits at half the unlimited controller's peaks
    (the setpoint kick and the load's recovery both saturate)."""
    if kind == "none":
        return None
    if kind == "wide":
        return (-1e6, 1e6)
    free = simulate_loop(num, den, delay, pid)
    return (min(0.5 * float(np.min(free.u)), 0.0), max(0.5 * float(np.max(free.u)), 0.0))


@pytest.mark.parametrize("kind", ["none", "wide", "binding", "binding, windup"])
@pytest.mark.parametrize("case", CASES, ids=list(CASES))
def test_the_blocks_are_the_per_sample_loop(case, kind, monkeypatch):
    num, den, delay, pid = CASES[case]
    limits = _limits(num, den, delay, pid, kind)
    aw = kind != "binding, windup"
    calls = []
    real = loop._sample_loop
    monkeypatch.setattr(loop, "_sample_loop", lambda *a: (calls.append(1), real(*a))[1])
    fast = simulate_loop(num, den, delay, pid, u_limits=limits, anti_windup=aw)
    assert calls == []  # the blocks
    monkeypatch.undo()
    ref = _per_sample(monkeypatch, num, den, delay, pid, u_limits=limits, anti_windup=aw)
    assert np.array_equal(fast.t, ref.t)
    for a, b in ((fast.y, ref.y), (fast.u, ref.u)):
        assert np.max(np.abs(a - b)) <= 1e-9 * np.max(np.abs(b))
    for m, n in ((fast.setpoint, ref.setpoint), (fast.load, ref.load)):
        assert m.iae == pytest.approx(n.iae, rel=1e-7)  # small errors summed
        assert m.settling_time == pytest.approx(n.settling_time, rel=1e-7)  # interpolated
        assert m.overshoot == pytest.approx(n.overshoot, rel=1e-6, abs=1e-12)
        assert m.u_peak == pytest.approx(n.u_peak, rel=1e-9)
        assert m.saturated == n.saturated
    assert fast.setpoint.saturated == kind.startswith("binding")


def test_saturation_and_windup_show(monkeypatch):
    """The must-fail twin: held at half its peak the controller's output is clipped there
    and the response is another one (here the setpoint kick was what overshot: less
    overshoot, sooner settled); without anti-windup the integral winds up, the overshoot
    grows and the settling takes longer."""
    num, den, delay, pid = CASES["FOPDT PI"]
    free = simulate_loop(num, den, delay, pid)
    limits = _limits(num, den, delay, pid, "binding")
    held = simulate_loop(num, den, delay, pid, u_limits=limits)
    wound = simulate_loop(num, den, delay, pid, u_limits=limits, anti_windup=False)
    assert np.max(held.u) == pytest.approx(limits[1]) and held.setpoint.saturated
    assert np.max(np.abs(held.y - free.y)) > 0.3
    assert held.setpoint.overshoot < 0.5 * free.setpoint.overshoot
    assert wound.setpoint.overshoot > 2 * held.setpoint.overshoot
    assert wound.setpoint.settling_time > 1.1 * held.setpoint.settling_time


def test_a_loop_without_dead_time_stays_per_sample(monkeypatch):
    """No dead time: no block of known plant input; the per-sample loop (and its exact
    solution of the algebraic loop through a feedthrough)."""
    calls = []
    real = loop._sample_loop
    monkeypatch.setattr(loop, "_sample_loop", lambda *a: (calls.append(1), real(*a))[1])
    simulate_loop([1.2 * 9.0, 1.2], [6.0, 1.0], 0.0, Pid(Kc=0.5, Ti=6.0))
    assert calls == [1]
