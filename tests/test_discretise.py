"""Closed-form ZOH discretisation (pipeline.simulation.zoh) and the simulator's fast and
irregular paths: the same outputs as the matrix-exponential discretisation and the exact
superposition of step responses, at bounded cost."""

import numpy as np
import pytest
from scipy import signal

from pipeline.models import STRUCTURES, ProcessModel
from pipeline.simulation import engine as simulation
from pipeline.simulation import zoh as discretise
from pipeline.simulation.engine import simulate

PARAMS = {
    "first_order": {"K": 2.0, "T": 5.0},
    "second_order": {"K": 0.8, "zeta": 0.3, "wn": 1.0},
    "two_lags": {"K": 1.5, "T1": 10.0, "T2": 3.0},
    "n_lags": {"K": 2.0, "T": 1.5, "n": 2},
    "integrator": {"K": 0.3},
    "integrator_lag": {"K": 0.3, "T": 4.0},
    "zero_two_lags": {"K": 1.2, "Tz": -2.0, "T1": 6.0, "T2": 2.0},
    "lead_lag": {"K": 1.2, "Tz": 3.0, "T": 6.0},
    "lag_second_order": {"K": 0.9, "T": 3.0, "zeta": 0.15, "wn": 2.0},
}
EXTRA = [
    ProcessModel("second_order", {"K": 0.8, "zeta": 1.0, "wn": 1.0}),  # critically damped
    ProcessModel("second_order", {"K": 0.8, "zeta": 1.7, "wn": 1.0}),  # two real lags
    ProcessModel("two_lags", {"K": 1.5, "T1": 3.0, "T2": 3.0}),  # equal lags
    ProcessModel("n_lags", {"K": 2.0, "T": 1.5, "n": 1}),
    ProcessModel("lead_lag", {"K": 1.2, "Tz": -3.0, "T": 6.0}),
]
DT = 0.1


def test_every_structure_is_covered():
    assert set(PARAMS) == set(STRUCTURES)


def _reference(model, t, u, u0, y0):
    """The simulator before the closed forms: cont2discrete + lfilter for a whole-sample
    dead time, the FFT of the exact pulse response for a fractional one."""
    dt = t[1] - t[0]
    du = u - u0
    shift = model.delay / dt
    if abs(shift - round(shift)) < 1e-6:
        b, a, _ = signal.cont2discrete(model.num_den(), dt, method="zoh")
        y = signal.lfilter(np.ravel(b), np.ravel(a), du)
        k = round(shift)
        y = np.concatenate([np.zeros(k), y[: y.size - k]])
    else:
        h = simulation.pulse_response(model, dt, du.size)
        y = np.convolve(du, h)[: du.size]
    return y0 + y


MODELS = [ProcessModel(s, {**p, "delay": d}) for s, p in PARAMS.items()
          for d in (0.0, 3 * DT, 2.37 * DT)] + EXTRA


@pytest.mark.parametrize("model", MODELS, ids=lambda m: m.text())
def test_closed_form_equals_the_matrix_exponential(model):
    rng = np.random.default_rng(0)
    n = 3000
    t = np.arange(n) * DT
    u = 3.0 + np.repeat(rng.normal(size=n // 50 + 1), 50)[:n]
    ref = _reference(model, t, u, 3.0, 10.0) - 10.0
    got = simulate(model, t, u, 3.0, 10.0) - 10.0
    assert np.max(np.abs(got - ref)) <= 1e-12 * np.max(np.abs(ref))
    # the record's sample time passed in gives the same output without the check
    assert np.array_equal(simulate(model, t, u, 3.0, 10.0, dt=DT) - 10.0, got)


def test_no_matrix_exponential_per_call(monkeypatch):
    """The order <= 2 structures are discretised in closed form and cached per model and
    sample time: cont2discrete is never called."""
    def boom(*a, **k):
        raise AssertionError("cont2discrete called")

    monkeypatch.setattr(signal, "cont2discrete", boom)
    t = np.arange(500) * DT
    u = np.where(t > 5, 1.0, 0.0)
    m = ProcessModel("second_order", {"K": 1.0, "zeta": 0.4, "wn": 2.0, "delay": 0.2})
    first = simulate(m, t, u, 0.0, 0.0)
    hits = discretise._cached_filter.cache_info().hits
    same = ProcessModel("second_order", dict(m.params))  # an equal model, a new object
    assert np.array_equal(simulate(same, t, u, 0.0, 0.0), first)
    assert discretise._cached_filter.cache_info().hits == hits + 1


def test_memory_bounds_the_pulse_response():
    """The output at sample k depends on the input only back to k - memory: a simulation
    started at rest that many samples earlier agrees to rounding."""
    rng = np.random.default_rng(3)
    t = np.arange(20000) * DT
    u = np.repeat(rng.normal(size=200), 100)
    for m in (ProcessModel("two_lags", {"K": 1.5, "T1": 10.0, "T2": 3.0, "delay": 0.37}),
              ProcessModel("second_order", {"K": 1.0, "zeta": 0.2, "wn": 1.0}),
              ProcessModel("n_lags", {"K": 1.0, "T": 2.0, "n": 7}),
              ProcessModel("zero_two_lags", {"K": 1.0, "Tz": 40.0, "T1": 5.0, "T2": 4.9})):
        full = simulate(m, t, u, 0.0, 0.0)
        L = discretise.memory(m, DT)
        start = 15000 - L
        part = simulate(m, t[start:], u[start:], 0.0, 0.0)
        assert np.max(np.abs(part[L:] - full[15000:])) < 1e-12 * np.max(np.abs(full))
    assert discretise.memory(ProcessModel("integrator", {"K": 1.0}), DT) is None


# -- irregular grids (issue 13 item 16) ---------------------------------------------------

def _bimodal_grid(n: int) -> np.ndarray:
    """Bursts of 1 ms samples between 0.9 s gaps (the crafted grid of the issue)."""
    rng = np.random.default_rng(5)
    steps = np.where(rng.random(n - 1) < 0.5, 0.001, 0.9)
    return np.concatenate([[0.0], np.cumsum(steps)])


@pytest.mark.parametrize("model", [
    ProcessModel("first_order", {"K": 2.0, "T": 3.0, "delay": 0.35}),
    ProcessModel("second_order", {"K": 0.8, "zeta": 0.3, "wn": 1.2, "delay": 0.5}),
    ProcessModel("integrator_lag", {"K": 0.5, "T": 4.0, "delay": 0.3}),
    ProcessModel("lead_lag", {"K": 1.2, "Tz": -3.0, "T": 6.0, "delay": 0.9}),
    ProcessModel("n_lags", {"K": 1.0, "T": 0.8, "n": 4}),
], ids=lambda m: m.structure)
def test_bimodal_grid_is_exact_at_bounded_cost(model, monkeypatch):
    t = _bimodal_grid(1500)
    rng = np.random.default_rng(6)
    u = 1.0 + np.repeat(rng.normal(size=30), 50)
    # the reference: the held input as a sum of steps, each a closed-form step response
    du = np.diff(u, prepend=1.0)
    ref = np.full(t.size, 4.0)
    for k in np.flatnonzero(du):
        ref[k:] += du[k] * model.unit_step(t[k:] - t[k])
    computed = []
    real = discretise.transitions

    def counting(A, B, steps):
        computed.append(steps.size)
        return real(A, B, steps)

    monkeypatch.setattr(discretise, "transitions", counting)
    monkeypatch.setattr(simulation, "FEW_CHANGES", 0)  # the transitions' batch, not steps
    y = simulate(model, t, u, 1.0, 4.0)
    assert np.max(np.abs(y - ref)) < 1e-9 * np.max(np.abs(ref - 4.0))
    # distinct poles: the modes' closed form over chunks, no per-interval transitions;
    # repeated poles (the equal-lag chain): one batch of distinct intervals, the two
    # modes (with their float jitter) and the dead time's offsets into them
    if model.structure == "n_lags":
        assert len(computed) == 1 and computed[0] <= 400
    else:
        assert computed == []


def test_long_bimodal_grid_is_linear():
    """The 300 kB CSV of the issue (10,000 samples, 1 ms and 0.9 s intervals) with an input
    that changes at every sample: O(samples) memory (no fine grid over the record)."""
    t = _bimodal_grid(10_000)
    u = np.random.default_rng(7).normal(size=t.size)
    m = ProcessModel("first_order", {"K": 2.0, "T": 3.0, "delay": 0.35})
    y = simulate(m, t, u, 0.0, 0.0)
    # exact at the end against the superposition over the last part (the memory of the
    # model is far shorter than the record)
    k0 = t.size - 400
    start = int(np.searchsorted(t, t[k0] - 60.0))
    du = np.diff(u[start:], prepend=0.0)
    ref = np.zeros(t.size - start)
    ts = t[start:]
    for k in np.flatnonzero(du):
        ref[k:] += du[k] * m.unit_step(ts[k:] - ts[k])
    assert np.max(np.abs(y[k0:] - ref[k0 - start:])) < 1e-9
