"""Memory at scale (issue 14 item 6): the record-long passes that are now made a chunk at a
time give the same numbers, to the bit, as one pass over the whole array (a convolution:
to rounding), and the per-step gains' columns are made when the solver reaches them and
forgotten once settled, not all held at once."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from scipy import signal
from scipy.stats import rankdata

from pipeline import validate
from pipeline.analysis import AnalysisOptions, analyse
from pipeline.grading import consistency, ranks, superposition
from pipeline.grading import recommendation as recommend
from pipeline.models import STRUCTURES, ProcessModel, delayed_step
from pipeline.refine import joint, problem
from pipeline.report import drawing
from pipeline.segmentation.detect import SegmentOptions, segment
from pipeline.simulation import engine as simulation
from pipeline.simulation import regressors
from pipeline.synth import step_record


@pytest.mark.parametrize("chunk", [7, 1000])
def test_ranks_in_chunks_are_the_average_ranks(chunk, monkeypatch):
    monkeypatch.setattr(ranks, "CHUNK", chunk)
    rng = np.random.default_rng(4)
    for x in (rng.normal(size=12_345), np.round(rng.normal(size=12_345), 1),
              np.zeros(50), np.repeat(rng.normal(size=40), 300), np.arange(1.0)):
        got = ranks.average_ranks(x)
        assert np.array_equal(got, rankdata(x, method="average"))
        # twice the ranks as integers (half the memory with a 32-bit order): halved, the
        # same ranks to the bit
        order, new = ranks.sort_groups(x)
        twice = ranks.ranks_of(ranks.narrowed(order), new, doubled=True)
        assert twice.dtype == np.int32 and (twice / 2.0).tobytes() == got.tobytes()
    # the closed-loop check's signed ranks and their products, whole and in chunks
    from pipeline.grading import closed_loop

    d = np.round(rng.normal(size=5000), 1)
    monkeypatch.setattr(ranks, "CHUNK", 1 << 20)
    monkeypatch.setattr(closed_loop, "CHUNK", 1 << 20)
    whole = closed_loop._signed_ranks(d.copy())
    dot = closed_loop._dot(whole[1:], whole[:-1])
    monkeypatch.setattr(ranks, "CHUNK", chunk)
    monkeypatch.setattr(closed_loop, "CHUNK", chunk)
    got = closed_loop._signed_ranks(d.copy())
    assert np.array_equal(got, whole) and closed_loop._dot(got[1:], got[:-1]) == dot


def test_decimation_in_chunks_keeps_the_same_samples(monkeypatch):
    rng = np.random.default_rng(6)
    n = 50_000
    x = np.sort(rng.uniform(0.0, 100.0, n))
    y = np.sin(x) + rng.normal(0.0, 0.2, n)
    y[rng.uniform(size=n) < 0.05] = np.nan
    y[10_000:14_000] = np.nan  # a gap across chunk boundaries
    y[30_000] = np.inf
    whole = drawing.decimate(x, y, 300)
    for chunk in (7, 64, 333, 4096):  # a pixel column spans many chunks at 7
        monkeypatch.setattr(drawing, "CHUNK", chunk)
        got = drawing.decimate(x, y, 300)
        assert np.array_equal(got[0], whole[0])
        assert np.array_equal(got[1], whole[1], equal_nan=True)


@pytest.mark.parametrize("structure, params", [
    ("first_order", {"T": 6.2, "delay": 0.31}),
    ("second_order", {"zeta": 0.3, "wn": 0.8, "delay": 1.25}),
    ("lead_lag", {"Tz": 2.0, "T": 5.0, "delay": 0.0}),
    ("integrator", {"delay": 0.2}),
])
def test_forced_response_in_chunks_is_the_one_filter(structure, params, monkeypatch):
    rng = np.random.default_rng(8)
    t = np.arange(20_000) * 0.1
    u = 5.0 + np.cumsum(rng.normal(0.0, 0.01, t.size))
    p = {"K": 1.0, **params}
    whole = simulation.forced_response(structure, p, t, u - 5.0, 0.1)
    monkeypatch.setattr(simulation, "CHUNK", 999)  # the chunked path from 999 samples on
    got = simulation.forced_response(structure, p, t, u, 0.1, u0=5.0)
    assert got.tobytes() == whole.tobytes()
    # less another response, in that response's array: the same as the subtraction
    other = simulation.forced_response(structure, {**p, "delay": 0.05}, t, u, 0.1, u0=5.0)
    want = np.subtract(whole, other)
    got = simulation.forced_response(structure, p, t, u, 0.1, u0=5.0, minus=other)
    assert got is other and got.tobytes() == want.tobytes()


@pytest.mark.parametrize("params", [{"T": 0.8, "n": 3.0, "delay": 0.25},
                                    {"T": 0.5, "n": 2.5, "delay": 0.0}])
def test_a_long_convolution_in_chunks_is_the_whole_one_to_rounding(params, monkeypatch):
    """A model without a recursion (an equal-lag chain of order 3, a non-integer order):
    overlap-add over chunks of the input, the pulse response cut at the model's memory,
    gives the whole convolution to rounding; below a chunk nothing changes."""
    rng = np.random.default_rng(9)
    t = np.arange(30_000) * 0.1
    u = 5.0 + np.repeat(rng.normal(0.0, 1.0, 60), 500)  # steps every 50 s
    p = {"K": 1.0, **params}
    model = ProcessModel("n_lags", {**p, "K": 2.0})
    whole = simulation.forced_response("n_lags", p, t, u - 5.0, 0.1)
    public = simulation.simulate(model, t, u, 5.0, 1.0, dt=0.1)
    assert np.max(np.abs(whole)) > 1.0  # the steps move it
    assert np.max(np.abs(public - 1.0 - 2.0 * whole)) < 1e-12 * np.max(np.abs(public))
    for chunk in (999, 4096):  # the pulse response (a few hundred samples) spans chunks
        monkeypatch.setattr(simulation, "CHUNK", chunk)
        got = simulation.forced_response("n_lags", p, t, u, 0.1, u0=5.0)
        assert np.max(np.abs(got - whole)) < 1e-12 * np.max(np.abs(whole))
        got = simulation.simulate(model, t, u, 5.0, 1.0, dt=0.1)
        assert np.max(np.abs(got - public)) < 1e-12 * np.max(np.abs(public))
    # below a chunk: one convolution of the pulse response over the whole input, as
    # before chunks (the same numbers to the bit)
    k = np.arange(t.size) * 0.1
    h = np.diff(delayed_step(STRUCTURES["n_lags"], p, k), prepend=0.0)
    h = h[: np.flatnonzero(np.abs(h) > 1e-15 * np.abs(h).sum())[-1] + 1]
    assert whole.tobytes() == signal.oaconvolve(u - 5.0, h)[: t.size].tobytes()
    h = simulation.pulse_response(model, 0.1, t.size)
    assert public.tobytes() == (signal.oaconvolve(u - 5.0, h)[: t.size] + 1.0).tobytes()


def test_step_gain_columns_are_made_when_needed_and_dropped_when_settled(monkeypatch):
    truth = ProcessModel("first_order", {"K": 2.0, "T": 5.0, "delay": 0.5})
    rng = np.random.default_rng(0)
    per, dt, n_events = 3000, 0.01, 48
    changes = [((i + 0.5) * per * dt, float(2 + rng.uniform(-1, 1))) for i in range(n_events)]
    rec = step_record(truth, u0=2.0, changes=changes, t_end=(n_events * per - 1) * dt,
                      dt=dt, y0=1.0, noise=0.02, seed=1)
    events = segment(rec, SegmentOptions())
    monkeypatch.setattr(superposition, "SPARSE_FROM", 1)  # the KKT route
    held, made, seen = [], [], []
    real_call, real_solve = superposition._Values.__call__, superposition.solve

    def spy(self, j):
        if self.cols[j].values is None and j not in self.kept:
            made.append(j)
        out = real_call(self, j)
        held.append(len(self.kept))
        return out

    def solve(cols, y):
        seen.extend(cols)
        return real_solve(cols, y)

    monkeypatch.setattr(superposition._Values, "__call__", spy)
    monkeypatch.setattr(superposition, "solve", solve)
    gains = consistency.step_gains(rec, events, truth)
    assert len(gains) == len(events)
    covered = [lo < 2.0 < hi for _, _, (lo, hi), _, _ in gains.values()]
    assert np.mean(covered) >= 0.85  # 95 % intervals (a few misses among 48 are chance)
    assert all(abs(K - 2.0) < 0.05 for K, *_ in gains.values())
    # held at once: the columns moving at one sample (a window and the model's memory
    # after it) and those that run to the end of the record, not every event's
    n = rec.n_samples
    moving = max(len(m) for _, _, _, m in superposition._segments(seen, n))
    to_end = sum(c.stop == n for c in seen)
    assert max(held) <= moving + to_end < len(events)
    # each column made once for the system and once for the residuals
    assert max(np.bincount(made)) <= 2


@pytest.mark.parametrize("structure, state", [
    ("first_order", "rest"), ("two_lags", "estimated"), ("integrator_lag", "estimated"),
    ("integrator_lag", "steady"), ("lead_lag", "rest"), ("zero_two_lags", "estimated")])
@pytest.mark.parametrize("chunk", [999, problem.CHUNK])
def test_a_refinement_design_kept_as_columns_is_the_stacked_one(structure, state, chunk,
                                                                monkeypatch):
    """A refinement over a long span keeps its design as columns (issue 14 item 6):
    reduced to criterion rows a column at a time they are the stacked design's rows to
    the bit, also when each column is made and reduced before the next (``design_rows``,
    ``rows_of`` for several masks: the change per unit of a linear parameter made in the
    array of the response at 0, chunk by chunk on a long span); multiplied out a chunk of
    samples at a time, its product. The span's times and input are the caller's arrays,
    and the time since the span start is made only for the columns that need it."""
    monkeypatch.setattr(simulation, "CHUNK", chunk)  # below the span: the chunked filter
    rng = np.random.default_rng(12)
    n, dt, u_ref = 12_000, 0.1, 4.0
    t = 100.0 + np.arange(n) * dt
    u = u_ref + np.repeat(rng.normal(0.0, 1.0, 24), n // 24)
    y = rng.normal(size=n)
    mask = np.ones(n, bool)
    mask[3000:4500] = mask[9000:9100] = False  # gaps: rows never straddle them
    spec = STRUCTURES[structure]
    p = {"T": 3.0, "T1": 4.0, "T2": 1.5, "delay": 0.35, "Tz": 1.2}
    p = {k: v for k, v in p.items() if k in spec.params}
    for max_rows, linear in ((600, ()), (n, ()), (600, ("Tz",) if "Tz" in p else ())):
        prob = problem.Problem.of(t, u, y, structure, u_ref=u_ref, mask=mask,
                                  initial_state=state, free_lags=3, max_rows=max_rows)
        prob = dataclasses.replace(prob, linear=linear)
        assert prob.t is t and prob.u is u  # not copied
        cols = prob.columns(p)
        assert (prob.t_rel is not None) == (state != "rest")
        # the stacked design as refine built it before: the forced response from the
        # input's deviation, the offset, the nuisance columns
        t_rel, q = t - t[0], {**p, **dict.fromkeys(linear, 0.0)}
        x0 = simulation.forced_response(structure, q, t_rel, u - u_ref, prob.dt)
        xs = [simulation.forced_response(structure, {**q, n_: 1.0}, t_rel, u - u_ref, prob.dt)
              - x0 for n_ in linear]
        nuis = [np.ones(n)]
        if spec.integrating and state != "rest":
            nuis.append(regressors.offset_response(structure, q, t_rel) if state == "estimated"
                        else t_rel)
        if state == "estimated":
            nuis.extend(regressors.free_basis(structure, q, t_rel, prob.horizon).T)
        stacked = np.column_stack([x0, *xs, *nuis])
        assert prob.reduce(cols).tobytes() == prob.rows(stacked).tobytes()
        assert prob.design_rows(p).tobytes() == prob.rows(stacked).tobytes()
        # folds of the span (one with every sample a row: its rows are the column itself)
        others = [prob.with_mask(np.ones(n, bool), y, n), prob.with_mask(~mask, y, 500),
                  prob.with_mask(mask, y, max_rows, keep_mask=False)]
        for f, got in zip(others, prob.rows_of(p, others), strict=True):
            assert got.tobytes() == f.rows(stacked).tobytes()
        c = rng.normal(size=stacked.shape[1])
        whole = (stacked @ c)[mask]
        for chunk in (1024, 4096, n):  # each row by the same coefficients (the same bits
            # where the matrix-vector product's rows do not depend on the rows beside them)
            got = cols.product(c, mask, chunk=chunk)
            np.testing.assert_allclose(got, whole, rtol=1e-15, atol=1e-15 * np.abs(whole).max())
        # a last single row is not a chunk of its own (numpy's dot product for one row
        # rounds differently from the matrix-vector product): n - 1 is the whole product
        for _ in range(20):
            c = rng.normal(size=stacked.shape[1])
            assert cols.product(c, mask, chunk=n - 1).tobytes() == \
                cols.product(c, mask, chunk=n).tobytes()


def test_fold_errors_merged_run_by_run_are_the_sorted_concatenation(monkeypatch):
    """A joint fit's held-out errors (interleaved folds) come back in time order from
    its folds' simulated runs placed one after another (issue 14 item 6), the same
    arrays as the folds' errors concatenated and sorted; runs that overlap would be
    sorted the same way."""
    truth = ProcessModel("first_order", {"K": 2.0, "T": 3.0, "delay": 0.4})
    changes = [(20.0 + 25.0 * i, 5.0 + (1.0 if i % 2 == 0 else -1.0)) for i in range(13)]
    rec = step_record(truth, u0=5.0, changes=changes, t_end=360.0, dt=0.1, y0=1.0,
                      noise=0.02, seed=3)
    res = analyse(rec, AnalysisOptions(events="all", methods=("lsq_first_order",),
                                       consistency=False))
    fit = next(f for f in res.fits if f.ok and f.events)
    folds = fit.refinement.folds
    assert len(folds) == joint.MAX_FOLDS < len(res.events)  # interleaved folds
    sorts = []
    real_argsort = np.argsort
    monkeypatch.setattr(np, "argsort", lambda *a, **k: sorts.append(1) or real_argsort(*a, **k))
    idx, e = recommend.held_out(fit, res)
    assert not sorts  # disjoint runs: copied in time order, not sorted
    monkeypatch.undo()
    parts = [validate.heldout_residuals(m, rec, list(res.events), held, b)
             for held, m, b in joint.fold_models("first_order", folds)]
    whole = np.concatenate([p[0] for p in parts])
    order = np.argsort(whole, kind="stable")
    assert np.array_equal(idx, whole[order]) and np.all(np.diff(idx) > 0)
    assert e.tobytes() == np.concatenate([p[1] for p in parts])[order].tobytes()
    assert float(np.mean(e**2)) == pytest.approx(fit.metrics["mse_cross_validation"])
    # runs that overlap (disjoint events do not make them): sorted stably, as before
    runs = {0: [(slice(8, 12), np.zeros(4))], 1: [(slice(2, 5), np.ones(3)),
                                                  (slice(10, 13), np.full(3, 2.0))]}
    monkeypatch.setattr(recommend, "fold_models", lambda s, f: [([0], None, None),
                                                                ([1], None, None)])
    monkeypatch.setattr(recommend, "validation_simulation",
                        lambda m, r, ev, held, b: list(runs[held[0]]))
    idx, e = recommend.held_out(fit, res)
    assert idx.tolist() == [2, 3, 4, 8, 9, 10, 10, 11, 11, 12]
    np.testing.assert_allclose(rec.y[idx] - e, [1, 1, 1, 0, 0, 0, 2, 0, 2, 2], atol=1e-12)


def test_a_fold_without_its_mask_has_the_same_rows():
    """A cross-validation fold keeps its criterion rows, not a span-long mask
    (``keep_mask=False``): where the rows are blocks its rows of any column are the
    masked problem's; where every fit sample is a row the mask is needed and kept."""
    rng = np.random.default_rng(2)
    n = 5000
    t = np.arange(n) * 0.5
    u, y = rng.normal(size=n), rng.normal(size=n)
    mask = rng.uniform(size=n) < 0.7
    base = problem.Problem.of(t, u, y, "first_order", u_ref=0.0, mask=np.ones(n, bool),
                              initial_state="rest", free_lags=3, max_rows=600)
    x = rng.normal(size=n)
    for max_rows in (600, n):
        kept = base.with_mask(mask, y, max_rows)
        fold = base.with_mask(mask, y, max_rows, keep_mask=False)
        assert (fold.mask is None) == (max_rows < n)
        assert fold.rows(x).tobytes() == kept.rows(x).tobytes()
        assert fold.y.tobytes() == kept.y.tobytes()
        # the offset's rows are made from the blocks' lengths, without a column of ones
        assert fold.offset_rows.tobytes() == kept.rows(np.ones(n)).tobytes()
        p = {"T": 4.0, "delay": 1.0}
        assert fold.design_rows(p).tobytes() == kept.design_rows(p).tobytes()


def _blocks_from_indices(mask, max_rows):
    """The blocks and boundaries as first written: from the fit samples' index array
    (16 bytes a sample of temporaries on a long span)."""
    idx = np.flatnonzero(mask)
    m = max(1, -(-idx.size // max_rows))
    if m == 1:
        return np.arange(idx.size), np.ones(idx.size), None
    seg = np.flatnonzero(np.diff(idx) > 1) + 1
    edges = np.r_[0, seg, idx.size]
    starts = np.concatenate([np.arange(a, b, m)
                             for a, b in zip(edges[:-1], edges[1:], strict=True)])
    gaps = np.flatnonzero(mask[:-1] & ~mask[1:]) + 1
    bounds = np.union1d(idx[starts], gaps)
    return starts, np.diff(np.r_[starts, idx.size]).astype(float), \
        (bounds, np.searchsorted(bounds, idx[starts]))


def test_blocks_from_the_masks_runs_are_the_index_arrays_blocks():
    """:func:`pipeline.refine.lstsq.blocks` and ``block_bounds`` work from the mask's runs, not
    the fit samples' index array: the same starts, sizes, boundaries and rows on random
    masks (runs at the edges, single samples, empty and full masks)."""
    from pipeline.refine import lstsq

    rng = np.random.default_rng(7)
    for trial in range(3000):
        n = int(rng.integers(0, 300))
        mask = (rng.uniform(size=n) < rng.uniform()) if trial % 3 else np.zeros(n, bool)
        if trial % 3 == 2:
            for _ in range(int(rng.integers(1, 6))):
                a = int(rng.integers(0, max(n, 1)))
                mask[a: a + int(rng.integers(0, 60))] = True
        max_rows = int(rng.integers(1, 40))
        starts, counts, bb = _blocks_from_indices(mask, max_rows)
        got = lstsq.blocks(mask, max_rows)
        assert np.array_equal(got[0], starts) and np.array_equal(got[1], counts)
        if bb is not None:
            bounds, keep = lstsq.block_bounds(mask, got[0])
            assert np.array_equal(bounds, bb[0]) and np.array_equal(keep, bb[1])
