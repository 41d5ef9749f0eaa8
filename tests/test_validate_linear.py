"""Validation and per-event consistency in O(samples) per model (issue 14 item 4): a late
held-out event is simulated from the model's memory before it, not from the record start,
and the per-event gains are solved without the dense samples x events matrix, with the
same results."""

import numpy as np
import pytest

from pipeline import validate
from pipeline.grading import consistency, superposition
from pipeline.models import ProcessModel
from pipeline.segmentation.detect import SegmentOptions, segment
from pipeline.simulation.engine import simulate
from pipeline.simulation.zoh import memory
from pipeline.synth import step_record
from pipeline.uncertainty import covariance, variance_factor

TRUTH = ProcessModel("first_order", {"K": 2.0, "T": 5.0, "delay": 0.5})


def _log(n_events: int = 24, per: int = 3000, dt: float = 0.01):
    rng = np.random.default_rng(0)
    levels = 2 + rng.uniform(-1, 1, n_events)
    changes = [((i + 0.5) * per * dt, float(levels[i])) for i in range(n_events)]
    rec = step_record(TRUTH, u0=2.0, changes=changes, t_end=(n_events * per - 1) * dt,
                      dt=dt, y0=1.0, noise=0.02, seed=1)
    return rec, segment(rec, SegmentOptions())


def _simulated_lengths(monkeypatch) -> list[int]:
    """The lengths validation simulates, appended as it goes."""
    lengths: list[int] = []
    real = validate.forced_response

    def counting(structure, p, t, du, dt=None, **kw):
        lengths.append(t.size)
        return real(structure, p, t, du, dt, **kw)

    monkeypatch.setattr(validate, "forced_response", counting)
    return lengths


MODELS = [
    ProcessModel("first_order", {"K": 2.01, "T": 5.05, "delay": 0.5}),
    ProcessModel("two_lags", {"K": 2.0, "T1": 4.6, "T2": 0.5, "delay": 0.43}),
    ProcessModel("second_order", {"K": 2.0, "zeta": 0.6, "wn": 0.4, "delay": 0.45}),
    ProcessModel("lead_lag", {"K": 2.0, "Tz": 0.5, "T": 5.0, "delay": 0.5}),
]


@pytest.mark.parametrize("model", MODELS, ids=lambda m: m.structure)
def test_late_event_scored_from_its_memory_equals_the_whole_record(model, monkeypatch):
    rec, events = _log()
    j = len(events) - 2
    lengths = _simulated_lengths(monkeypatch)
    idx, e = validate.heldout_residuals(model, rec, events, [j])
    # the reference: the model driven from the first sample of the record, at rest at the
    # first event's operating point, the offset estimated on the same warm-up
    first = events[0]
    full = simulate(model, rec.t, rec.u, first.u0, first.y0)
    w = validate.warmup(events, events[j])
    a, b = events[j].i_start, events[j].i_end
    ref = rec.y[a:b] - (full[a:b] + np.mean(rec.y[w] - full[w]))
    assert np.array_equal(idx, np.arange(a, b))
    assert np.max(np.abs(e - ref)) < 1e-9 * np.max(np.abs(rec.y[a:b] - first.y0))
    # simulated over its memory, the warm-up and the event, not the 70,000 samples before
    mem = memory(model, rec.sample_time)
    assert lengths == [b - w.start + mem] or lengths == [b]  # b: memory covers the start
    assert lengths[0] < rec.n_samples / 2


def test_integrating_model_still_simulated_from_the_start(monkeypatch):
    rec, events = _log(n_events=8)
    lengths = _simulated_lengths(monkeypatch)
    m = ProcessModel("integrator_lag", {"K": 0.4, "T": 5.0, "delay": 0.5})
    validate.heldout_residuals(m, rec, events, [6])
    assert lengths == [events[6].i_end]


def _dense_step_gains(rec, events, shape):
    """step_gains as it was: every column simulated over the whole record, X dense."""
    t, u, y = rec.t, rec.u, rec.y
    unit = ProcessModel(shape.structure, {**shape.params, "K": 1.0})
    starts = [e.i_start for e in events] + [t.size]
    ref = float(u[max(starts[0] - 1, 0)])
    cols = []
    for j in range(len(events)):
        a, b = starts[j], starts[j + 1]
        before = ref if j == 0 else float(u[a - 1])
        d = np.zeros(t.size)
        d[a:b] = u[a:b] - before
        d[b:] = d[b - 1] if b > a else 0.0
        cols.append(simulate(unit, t, d, 0.0, 0.0))
    X = np.column_stack([np.ones(t.size), *cols])
    coef, *_ = np.linalg.lstsq(X, y, rcond=None)
    e = y - X @ coef
    cov = covariance(X, e, X.shape[1], variance_factor(e))
    return coef, np.sqrt(np.diag(cov)), e


@pytest.mark.parametrize("sparse", [False, True], ids=["compressed", "kkt"])
@pytest.mark.parametrize("model", MODELS[:3], ids=lambda m: m.structure)
def test_step_gains_without_the_dense_matrix(model, sparse, monkeypatch):
    """Both solvers of :mod:`pipeline.grading.superposition` against the dense least squares:
    the same gains and standard errors, and neither builds the samples x events matrix
    (the compressed one solves a few rows per event; the KKT one a sparse system of
    about five unknowns per event)."""
    rec, events = _log(n_events=16, per=2000)
    coef, se, e = _dense_step_gains(rec, events, model)
    monkeypatch.setattr(superposition, "SPARSE_FROM", 1 if sparse else 10**9)
    used = []
    for name in ("compressed", "kkt"):
        real = getattr(superposition, name)

        def spy(cols, y, *values, real=real, name=name):
            out = real(cols, y, *values)
            used.append(name)
            return out

        monkeypatch.setattr(superposition, name, spy)
    got = consistency.step_gains(rec, events, model)
    assert used == ["kkt" if sparse else "compressed"]
    assert set(got) == {ev.index for ev in events}
    for ev in events:
        K, K_se, _, _, _ = got[ev.index]
        assert K == pytest.approx(coef[ev.index + 1], rel=1e-9)
        assert K_se == pytest.approx(se[ev.index + 1], rel=1e-8)


def test_step_gains_with_collinear_columns_fall_back_to_the_svd():
    """Two identical columns make the KKT system singular: the compressed solver's SVD
    gives the minimum-norm answer instead, as the dense least squares does."""
    n = 400
    vals = np.linspace(0.0, 1.0, 100)
    cols = [superposition.Column(100, 200, vals, 1.0), superposition.Column(100, 200, vals, 1.0)]
    y = np.ones(n)
    y[100:200] += 3.0 * vals
    y[200:] += 3.0
    old = superposition.SPARSE_FROM
    try:
        superposition.SPARSE_FROM = 1
        sol = superposition.solve(cols, y)
    finally:
        superposition.SPARSE_FROM = old
    assert sol.coef == pytest.approx([1.0, 1.5, 1.5], rel=1e-9)
    assert np.max(np.abs(sol.residuals)) < 1e-9


def test_events_far_apart_are_simulated_each_from_its_memory(monkeypatch):
    """Held-out events spread over a long record: one short simulation per event (not
    one from the first to the last), and the same errors as the model driven through the
    whole record."""
    rec, events = _log()
    model = MODELS[0]
    held = [3, 12, 21]
    lengths = _simulated_lengths(monkeypatch)
    idx, e = validate.heldout_residuals(model, rec, events, held)
    first = events[0]
    full = simulate(model, rec.t, rec.u, first.u0, first.y0)
    ref = []
    for j in held:
        w = validate.warmup(events, events[j])
        a, b = events[j].i_start, events[j].i_end
        ref.append(rec.y[a:b] - (full[a:b] + np.mean(rec.y[w] - full[w])))
    ref = np.concatenate(ref)
    assert np.array_equal(idx, np.concatenate([np.arange(events[j].i_start, events[j].i_end)
                                               for j in held]))
    assert np.max(np.abs(e - ref)) < 1e-9 * np.max(np.abs(rec.y - first.y0))
    mem = memory(model, rec.sample_time)
    assert len(lengths) == 3 and max(lengths) <= 3000 + mem + 3000


def test_nearly_collinear_columns_and_femto_units_get_the_svd_answer(monkeypatch):
    """Columns equal to 1e-12 (variance inflation ~1e24) are not left to the KKT solve,
    whose answer there is arbitrary: the SVD's minimum-norm one, as for exact
    collinearity. A femto-unit column is not cut off by the SVD's relative threshold."""
    monkeypatch.setattr(superposition, "SPARSE_FROM", 1)
    vals = np.linspace(0.0, 1.0, 100)
    y = np.ones(400)
    y[100:200] += 3.0 * vals
    y[200:] += 3.0
    near = [superposition.Column(100, 200, vals, 1.0),
            superposition.Column(100, 200, vals * (1 + 1e-12), 1.0 + 1e-12)]
    sol = superposition.solve(near, y)
    assert sol.coef == pytest.approx([1.0, 1.5, 1.5], rel=1e-6)
    femto = [superposition.Column(100, 200, 1e-15 * vals, 1e-15)]
    sol = superposition.compressed(femto, y)
    assert sol.coef == pytest.approx([1.0, 3e15], rel=1e-9)


def test_an_event_named_twice_is_validated_once():
    """Runs are corrected in place: an event listed twice must not be corrected twice."""
    rec, events = _log(n_events=8)
    once = validate.heldout_residuals(MODELS[0], rec, events, [3, 5])
    twice = validate.heldout_residuals(MODELS[0], rec, events, [5, 3, 3])
    assert np.array_equal(once[0], twice[0]) and np.array_equal(once[1], twice[1])
