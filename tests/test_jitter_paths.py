"""Jittered time stamps on the fast exact paths (issue 30 item 4): the modes' closed form
(:func:`pipeline.simulation.engine._propagate_modal`) and the clustered matrix exponential
(:func:`pipeline.simulation.zoh.expm_near`) give the per-interval loop's and ``expm``'s
numbers to rounding, on a 1 % jittered grid with the dead time's offsets."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import linalg

from pipeline.models import ProcessModel
from pipeline.simulation import engine, zoh


def _grid(n=800, seed=1):
    rng = np.random.default_rng(seed)
    t = np.cumsum(rng.uniform(0.99, 1.01, n))
    return t - t[0]


MODELS = [
    ProcessModel("first_order", {"K": 2.0, "T": 20.0, "delay": 3.3}),
    ProcessModel("first_order", {"K": 2.0, "T": 0.05, "delay": 0.0}),  # far below a sample
    ProcessModel("second_order", {"K": 1.5, "zeta": 0.3, "wn": 0.2, "delay": 1.7}),
    ProcessModel("two_lags", {"K": 1.0, "T1": 30.0, "T2": 4.0, "delay": 0.5}),
    ProcessModel("zero_two_lags", {"K": 1.0, "Tz": -5.0, "T1": 30.0, "T2": 4.0}),
    ProcessModel("integrator_lag", {"K": 0.1, "T": 5.0, "delay": 2.0}),
    ProcessModel("lead_lag", {"K": 1.2, "Tz": 9.0, "T": 6.0, "delay": 0.9}),
]


@pytest.mark.parametrize("model", MODELS, ids=lambda m: m.structure)
def test_the_modes_closed_form_is_the_loop(model, monkeypatch):
    t = _grid()
    u = 1.0 + np.repeat(np.random.default_rng(2).normal(size=16), 50)
    fast = engine.simulate_irregular(model, t, u, 1.0, 4.0)
    monkeypatch.setattr(engine, "_propagate_modal", lambda *a: None)
    loop = engine.simulate_irregular(model, t, u, 1.0, 4.0)
    assert np.max(np.abs(fast - loop)) <= 1e-11 * max(np.max(np.abs(loop - 4.0)), 1e-300)


def test_a_repeated_pole_leaves_the_closed_form():
    A, B, _, _ = zoh.state_space(ProcessModel("n_lags", {"K": 1.0, "T": 5.0, "n": 3}))
    assert engine._propagate_modal(A, B[:, 0], _grid(50), np.ones(50)) is None


@pytest.mark.parametrize("model", [ProcessModel("n_lags", {"K": 1.0, "T": 5.0, "n": 4}),
                                   ProcessModel("two_lags", {"K": 1.0, "T1": 5.0, "T2": 5.0}),
                                   ProcessModel("n_lags", {"K": 1.0, "T": 0.05, "n": 3})],
                         ids=["n_lags", "equal_two_lags", "fast_chain"])
def test_the_clustered_exponential_is_expm(model):
    A, B, _, _ = zoh.state_space(model)
    n = A.shape[0]
    M = np.zeros((n + 1, n + 1))
    M[:n, :n], M[:n, n:] = A, B
    rng = np.random.default_rng(0)
    steps = np.concatenate([[0.0], rng.uniform(0.98, 1.02, 300), rng.uniform(0.29, 0.31, 300),
                            [3.0, 1e-6, 250.0]])
    ref = linalg.expm(M[None] * steps[:, None, None])
    assert np.max(np.abs(zoh.expm_near(M, steps) - ref)) < 1e-13 * np.max(np.abs(ref))


@pytest.mark.parametrize("changes", [5, 200])
def test_an_equal_lag_chain_on_jittered_stamps(changes):
    """Repeated poles: a staircase (5 changes) by superposition of closed-form steps, a
    busy input (200) by the transitions; both the loop's numbers."""
    m = ProcessModel("n_lags", {"K": 1.3, "T": 6.0, "n": 4, "delay": 1.4})
    t = _grid()
    u = 1.0 + np.repeat(np.random.default_rng(3).normal(size=changes), t.size // changes)
    u = np.concatenate([u, np.full(t.size - u.size, u[-1])])
    fast = engine.simulate_irregular(m, t, u, 1.0, 0.0)
    ref = np.zeros(t.size)
    du = np.diff(u, prepend=1.0)
    for k in np.flatnonzero(du):
        ref[k:] += du[k] * m.unit_step(t[k:] - t[k])
    assert np.max(np.abs(fast - ref)) <= 1e-9 * np.max(np.abs(ref))


def test_a_gap_longer_than_a_chunk_stays_finite(monkeypatch):
    """Review: one interval longer than the modal span (a 5000 s gap) overflowed the
    scaled terms into NaN after it; it is stepped directly now, as the loop does."""
    t = _grid(2000)
    t[1000:] += 5000.0
    u = 1.0 + np.repeat(np.random.default_rng(4).normal(size=20), 100)
    for model in (MODELS[0], MODELS[2], MODELS[5]):
        fast = engine.simulate_irregular(model, t, u, 1.0, 0.0)
        with monkeypatch.context() as mp:
            mp.setattr(engine, "_propagate_modal", lambda *a: None)
            loop = engine.simulate_irregular(model, t, u, 1.0, 0.0)
        assert np.all(np.isfinite(fast))
        assert np.max(np.abs(fast - loop)) <= 1e-10 * np.max(np.abs(loop))


def test_the_clustered_exponential_of_a_huge_matrix():
    """Review: ||M|| above 1e17 overflowed the Taylor powers into NaN."""
    A, B, _, _ = zoh.state_space(ProcessModel("n_lags", {"K": 1.0, "T": 1e-18, "n": 3}))
    M = np.zeros((4, 4))
    M[:3, :3], M[:3, 3:] = A, B
    steps = np.array([1.0, 2.0, 1e-3, 1.0 + 1e-20])
    got = zoh.expm_near(M, steps)
    ref = linalg.expm(M[None] * steps[:, None, None])
    assert np.all(np.isfinite(got)) and np.allclose(got, ref, rtol=1e-12, atol=1e-12)
