"""simulate: exact ZOH responses against closed forms and python-control."""

import control
import numpy as np
import pytest

from pipeline.models import ProcessModel
from pipeline.simulation.engine import simulate

MODELS = [
    ProcessModel("first_order", {"K": 2.5, "T": 7.0}),
    ProcessModel("first_order", {"K": 2.0, "T": 0.5, "delay": 0.3}),
    ProcessModel("first_order", {"K": 2.0, "T": 0.5, "delay": 0.0123}),  # fractional delay
    ProcessModel("second_order", {"K": 0.25, "zeta": 0.31, "wn": 5.05}),
    ProcessModel("second_order", {"K": 1.0, "zeta": 1.7, "wn": 2.0}),
    ProcessModel("two_lags", {"K": 2.0, "T1": 1.0, "T2": 0.1}),
    ProcessModel("n_lags", {"K": 2.0, "T": 0.5, "n": 5}),
    ProcessModel("n_lags", {"K": 2.0, "T": 0.5, "n": 2.5}),
]


@pytest.mark.parametrize("model", MODELS, ids=lambda m: m.text())
def test_step_matches_closed_form(model):
    dt = 0.001
    t = np.arange(20000) * dt
    u = np.where(np.arange(t.size) >= 1000, 3.0, 1.0)
    y = simulate(model, t, u, 1.0, -4.0)
    exact = -4.0 + 2.0 * model.unit_step(t - 1.0)
    assert np.max(np.abs(y - exact)) < 1e-9


@pytest.mark.parametrize("n,T", [(5, 0.5), (20, 0.1)])
def test_high_order_chains_at_1ms(n, T):
    """(0.5s+1)^5 and (0.1s+1)^20 at 1 ms: an expanded polynomial would be useless here."""
    from scipy.special import gammainc

    t = np.arange(0, 10, 0.001)
    u = np.ones_like(t)
    y = simulate(ProcessModel("n_lags", {"K": 1.0, "T": T, "n": n}), t, u, 0.0, 0.0)
    assert np.max(np.abs(y - gammainc(n, t / T))) < 1e-10


@pytest.mark.parametrize("model", [m for m in MODELS if m.num_den() and m.delay == 0],
                         ids=lambda m: m.text())
def test_random_input_matches_python_control(model):
    rng = np.random.default_rng(1)
    t = np.arange(3000) * 0.01
    u = np.repeat(rng.normal(size=300), 10)
    y = simulate(model, t, u, 0.0, 0.0)
    ref = control.forced_response(control.c2d(model.transfer_function(), 0.01, "zoh"), t, u)
    # python-control discretises the expanded polynomial: ~1e-7 for a 5th-order chain
    assert np.max(np.abs(y - ref.outputs)) < 1e-6 * max(1.0, np.max(np.abs(y)))


def test_irregular_grid_close_to_exact():
    rng = np.random.default_rng(2)
    t = np.cumsum(rng.uniform(0.009, 0.011, 3000))
    u = np.where(t >= 5.0, 1.0, 0.0)
    m = ProcessModel("first_order", {"K": 2.0, "T": 3.0})
    y = simulate(m, t, u, 0.0, 0.0)
    assert np.max(np.abs(y - m.unit_step(t - t[np.argmax(t >= 5.0)]))) < 1e-12  # exact


def test_operating_point_is_kept():
    t = np.arange(100) * 0.1
    m = ProcessModel("first_order", {"K": 21.0, "T": 60.0})
    y = simulate(m, t, np.full(100, 6.0), 6.0, 129.0)
    assert np.allclose(y, 129.0)
