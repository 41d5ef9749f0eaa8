"""A step test on jittered stamps (issue 30 item 4): a staircase input is simulated by the
superposition of closed-form step responses, which costs a few ns a point where the
modes' chunked sums and, for repeated poles, the per-interval loop cost far more; the
numbers are the loop's (the exact ZOH state propagation, one matrix exponential per
interval) to rounding, near equal lags too, where the textbook two-lag form cancels."""

from __future__ import annotations

import numpy as np
import pytest

from pipeline.models import ProcessModel
from pipeline.responses import two_lag_impulse, two_lag_step
from pipeline.simulation import engine


def _grid(n=700, seed=11):
    rng = np.random.default_rng(seed)
    t = np.cumsum(rng.uniform(0.99, 1.01, n))  # a logger's 1 % jitter
    return t - t[0]


def _staircase(t, changes, seed=12):
    levels = 1.0 + np.random.default_rng(seed).normal(size=changes)
    return levels[np.minimum(np.arange(t.size) * changes // t.size, changes - 1)]


MODELS = [
    ProcessModel("first_order", {"K": 2.0, "T": 20.0, "delay": 3.3}),
    ProcessModel("second_order", {"K": 1.5, "zeta": 0.3, "wn": 0.2, "delay": 1.7}),
    ProcessModel("second_order", {"K": 1.5, "zeta": 1.0, "wn": 0.2, "delay": 0.4}),
    ProcessModel("two_lags", {"K": 1.0, "T1": 30.0, "T2": 4.0, "delay": 0.5}),
    ProcessModel("two_lags", {"K": 1.0, "T1": 12.0, "T2": 12.0, "delay": 2.5}),
    ProcessModel("two_lags", {"K": 1.0, "T1": 12.0, "T2": 12.0 * (1 - 1e-7)}),
    ProcessModel("zero_two_lags", {"K": 1.0, "Tz": -5.0, "T1": 9.0, "T2": 9.0 * (1 - 1e-6),
                                   "delay": 1.2}),
    ProcessModel("integrator_lag", {"K": 0.1, "T": 5.0, "delay": 2.0}),
    ProcessModel("lead_lag", {"K": 1.2, "Tz": 9.0, "T": 6.0, "delay": 0.9}),
    ProcessModel("n_lags", {"K": 1.3, "T": 6.0, "n": 4, "delay": 1.4}),
]


def _loop(model, t, u, monkeypatch):
    """The per-interval propagation: no superposition, no modes."""
    with monkeypatch.context() as mp:
        mp.setattr(engine, "SUPERPOSED_FIRST", -1)
        mp.setattr(engine, "FEW_CHANGES", -1)
        mp.setattr(engine, "_propagate_modal", lambda *a: None)
        return engine.simulate_irregular(model, t, u, 1.0, 4.0)


@pytest.mark.parametrize("model", MODELS, ids=lambda m: f"{m.structure}-{m.params}")
def test_a_staircase_is_superposed_and_is_the_loop(model, monkeypatch):
    t = _grid()
    u = _staircase(t, 5)
    calls = []
    for name in ("_propagate_modal", "_propagate"):
        real = getattr(engine, name)
        monkeypatch.setattr(engine, name, lambda *a, _r=real, _n=name: (calls.append(_n),
                                                                          _r(*a))[1])
    fast = engine.simulate_irregular(model, t, u, 1.0, 4.0)
    assert calls == []  # neither the modes nor the loop: the steps' closed forms
    monkeypatch.undo()
    loop = _loop(model, t, u, monkeypatch)
    assert np.max(np.abs(fast - loop)) <= 1e-11 * np.max(np.abs(loop - 4.0))


@pytest.mark.parametrize("model,path", [(MODELS[4], "superposed"), (MODELS[9], "superposed"),
                                        (MODELS[3], "modes"), (MODELS[0], "modes")],
                         ids=["equal_lags", "chain", "two_lags", "first_order"])
def test_more_changes_superposed_only_where_the_modes_refuse(model, path, monkeypatch):
    """20 changes: distinct poles take the modes' closed form (cheaper at that many
    changes), repeated ones the steps' (not the loop); both the loop's numbers."""
    t = _grid()
    u = _staircase(t, 20)
    used = []
    real_sup, real_loop = engine._superposed, engine._propagate
    monkeypatch.setattr(engine, "_superposed", lambda *a: (used.append("superposed"),
                                                           real_sup(*a))[1])
    monkeypatch.setattr(engine, "_propagate", lambda *a: (used.append("loop"),
                                                          real_loop(*a))[1])
    fast = engine.simulate_irregular(model, t, u, 1.0, 4.0)
    assert used == (["superposed"] if path == "superposed" else [])
    monkeypatch.undo()
    loop = _loop(model, t, u, monkeypatch)
    assert np.max(np.abs(fast - loop)) <= 1e-10 * np.max(np.abs(loop - 4.0))


@pytest.mark.parametrize("gap", [1e-7, 1e-9, 1e-11, 0.0])
def test_two_lags_near_equal_without_cancellation(gap):
    """Against the series of the step response in the lags' difference about equal lags
    (``S = 1 - e^{-x}(1 + x) + d x^2 e^{-x}/2 + O(d^2)``, ``x = t/T1``, ``d = 1 - T2/T1``:
    a faster second lag, a faster response; the neglected term is of order 1e-14 here).
    The textbook form misses it by up to ~1e-16/d: at 1e-9 by about 1e-7 (the must-fail
    twin)."""
    T1 = 12.0
    T2 = T1 * (1 - gap)
    t = np.linspace(0.0, 150.0, 3001)
    x = t / T1
    # to first order in d: dS/dT2 at T2 = T1 is half of d/dT (1 - e^{-t/T}(1 + t/T)),
    # -x^2 e^{-x}/(2 T1) (the response is symmetric in the lags), and T2 - T1 = -d T1
    series = 1 - np.exp(-x) * (1 + x) + gap * x**2 * np.exp(-x) / 2
    assert np.max(np.abs(two_lag_step(t, T1, T2) - series)) < 2e-14
    textbook = 1.0 - (T1 * np.exp(-t / T1) - T2 * np.exp(-t / T2)) / (T1 - T2) if gap else None
    if gap and gap <= 1e-9:
        assert np.max(np.abs(textbook - series)) > 1e-8
    # the impulse response, its derivative in t: t e^{-x}/T1^2 (1 + d (1 - x/2)) + O(d^2)
    imp = t * np.exp(-x) / T1**2 * (1 + gap * (1 - x / 2))
    assert np.max(np.abs(two_lag_impulse(t, T1, T2) - imp)) < 1e-14


def test_two_lags_far_apart_agree_with_the_form_without_cancellation():
    """Beyond NEAR_EQUAL the textbook form is kept (the numbers lags far apart always
    gave); it agrees with the cancellation-free form to 1e-12 there, down to the seam."""
    t = np.linspace(0.0, 200.0, 4001)
    for T1, T2 in ((10.0, 1.0), (50.0, 0.01), (3.0, 2.0), (10.0, 10.0 * (1 - 2e-4))):
        a, x = 1.0 / T1, (1.0 / T2 - 1.0 / T1) * t
        phi = np.where(x == 0, 1.0, -np.expm1(-x) / np.where(x == 0, 1.0, x))
        exact = 1.0 - np.exp(-a * t) * (1.0 + a * t * phi)
        for got in (two_lag_step(t, T1, T2), two_lag_step(t, T2, T1)):
            assert np.max(np.abs(got - exact)) < 1e-12
