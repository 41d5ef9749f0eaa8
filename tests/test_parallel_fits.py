"""One record's fits spread over worker processes (issue 30 item 3): the same result as
in one process, the work really spread, a dead worker costing nothing but time, and short
logs never starting a pool."""

from __future__ import annotations

import os
import pickle

import numpy as np
import pytest

from pipeline import parallel
from pipeline.analysis import AnalysisOptions, analyse
from pipeline.batch import LazyPool, lazy_pool
from pipeline.batch import pool as pool_module
from pipeline.models import ProcessModel
from pipeline.results import RunResult
from pipeline.synth.plants import step_record


class PicklingWorkers:
    """Workers in this process that pickle every task and result, as a pool would, and
    count what they were given."""

    def __init__(self, size: int = 2):
        self.size = size
        self.calls: list[int] = []

    def map(self, fn, items):
        items = [pickle.loads(pickle.dumps(x)) for x in items]
        self.calls.append(len(items))
        return [pickle.loads(pickle.dumps(fn(x))) for x in items]


def staircase_record(n_steps: int = 6, window: float = 60.0, noise: float = 0.01, seed=3):
    """A first-order-plus-delay plant (K 2, T 8 s, 2 s delay) from 20 % open, stepped up
    and down every ``window`` seconds, 0.5 s samples, white noise."""
    model = ProcessModel("first_order", {"K": 2.0, "T": 8.0, "delay": 2.0})
    changes = [(window * (k + 1), 20.0 + (5.0 if k % 2 == 0 else 0.0) + k)
               for k in range(n_steps)]
    return step_record(model, u0=20.0, changes=changes, t_end=window * (n_steps + 1),
                       dt=0.5, y0=50.0, noise=noise, seed=seed)


def doc_without_times(res) -> dict:
    doc = RunResult([res], config="test", created="2026-01-01T00:00:00+00:00").to_doc()
    text = doc.model_dump(mode="json")

    def strip(x):
        if isinstance(x, dict):
            return {k: strip(v) for k, v in x.items() if k != "seconds"}
        if isinstance(x, list):
            return [strip(v) for v in x]
        return x
    return strip(text)


OPTIONS = AnalysisOptions(events="all", methods=("first_order", "lsq_first_order",
                                                 "lsq_second_order"))


def square(shared: int, x: int) -> int:
    return shared * x * x


def test_spread_keeps_the_order_of_the_tasks():
    w = PicklingWorkers(size=2)
    for n in (2, 3, 7, 8, 9, 31):
        assert parallel.spread(w, square, 3, list(range(n))) == [3 * x * x for x in range(n)]
    # at most CHUNKS_PER_WORKER chunks per worker, each a task of the map
    assert max(w.calls) == parallel.CHUNKS_PER_WORKER * 2
    assert parallel.spread(None, square, 2, [1, 2]) == [2, 8]


def test_short_records_and_single_tasks_stay_here():
    w = PicklingWorkers(size=2)
    n = parallel.MIN_SAMPLES
    assert parallel.worth_spreading(w, n - 1, 10, record_samples=n) is None
    assert parallel.worth_spreading(w, n, 1, record_samples=n) is None
    assert parallel.worth_spreading(PicklingWorkers(size=1), 10**6, 10,
                                    record_samples=10**6) is None
    assert parallel.worth_spreading(w, n, 10, record_samples=parallel.MAX_RECORD_SAMPLES + 1
                                    ) is None  # a record too long to copy for each chunk
    assert parallel.worth_spreading(w, n, 2, record_samples=n) is w
    rec = staircase_record(n_steps=4)  # 600 samples: nothing is spread
    res = analyse(rec, OPTIONS, workers=w)
    assert w.calls == [] and res.recommended is not None


@pytest.mark.parametrize("events", ["all", (0,)])
def test_spread_fits_equal_the_loop(monkeypatch, events):
    """Every stage that spreads (each event's methods, the joint fits, the held-out errors,
    the per-step consistency, the grading) gives the very fits the loop gives."""
    rec = staircase_record()
    opt = AnalysisOptions(events=events, methods=OPTIONS.methods, consistency=True)
    here = analyse(rec, opt)
    monkeypatch.setattr(parallel, "MIN_SAMPLES", 0)
    w = PicklingWorkers(size=2)
    spread = analyse(rec, opt, workers=w)
    assert doc_without_times(spread) == doc_without_times(here)
    # events "all": the 6 events' fits, 2 joint fits, the held-out errors of 20 fits (in
    # 8 chunks), no per-step refits (the events' own fits serve), the grading of 20 fits;
    # event 0 alone: the other 5 steps' refits, the grading of event 0's 3 fits
    assert len(here.events) == 6
    assert w.calls == ([6, 2, 8, 8] if events == "all" else [5, 3])
    assert here.recommended.model.params["K"] == pytest.approx(2.0, rel=0.03)
    assert here.consistency is not None and len(here.consistency.estimates) == 6


def exit_in_worker(x: tuple[int, int]) -> int:
    parent, value = x
    if os.getpid() != parent:
        os._exit(3)  # what the OOM killer leaves: the worker gone, nothing returned
    return 2 * value


def test_a_dead_worker_costs_only_time(monkeypatch):
    with lazy_pool(2) as pool:
        assert isinstance(pool, LazyPool)
        items = [(os.getpid(), k) for k in range(6)]
        warned = []
        monkeypatch.setattr(pool_module.log, "warning", lambda *a: warned.append(a))
        assert pool.map(exit_in_worker, items) == [2 * k for k in range(6)]
        assert len(warned) == 1 and "died" in warned[0][0]
        # the pool stays broken: the next stage runs here at once
        assert pool.map(exit_in_worker, items[:2]) == [0, 2]


def test_one_worker_is_no_pool():
    with lazy_pool(1) as pool:
        assert pool is None
    with pytest.raises(Exception, match="at least 1"), lazy_pool(0):
        pass


def test_real_processes_give_the_same_fits(monkeypatch):
    """A real two-process pool (the fork server, pickled records) and the loop: the same
    document, bit for bit, but the seconds."""
    rec = staircase_record(n_steps=4)
    here = analyse(rec, OPTIONS)
    monkeypatch.setattr(parallel, "MIN_SAMPLES", 0)
    warned = []
    monkeypatch.setattr(pool_module.log, "warning", lambda *a: warned.append(a))
    with lazy_pool(2) as pool:
        there = analyse(rec, OPTIONS, workers=pool)
    assert warned == []  # the workers did their part: none died, nothing was redone here
    assert doc_without_times(there) == doc_without_times(here)
    assert np.isfinite(there.recommended.metrics["mse_validation"]) or \
        there.recommended.metrics.get("mse_cross_validation") is not None


def test_a_one_file_run_spreads_its_fits(tmp_path, monkeypatch):
    """``pipeline run`` on a config naming one long log gives its fits to a pool of its
    own (the batch has nothing else to run in parallel), with the same results.json as
    ``--workers 1``."""
    import json

    import polars as pl

    from pipeline.run import run_config

    rec = staircase_record(n_steps=8, window=1600.0)  # 25,601 samples: above MIN_SAMPLES
    assert rec.n_samples >= parallel.MIN_SAMPLES
    pl.DataFrame({"time": rec.t, "u": rec.u, "y": rec.y}).write_csv(tmp_path / "log.csv")
    config = tmp_path / "c.yaml"
    config.write_text("data: {path: log.csv, input: u, output: y, time: time}\n"
                      "methods: [first_order, lsq_first_order]\n"
                      "identification: {events: all}\n"
                      "report: {plots: none}\n")
    calls = []
    real_map = LazyPool.map
    monkeypatch.setattr(LazyPool, "map", lambda self, fn, items: calls.append(len(items))
                        or real_map(self, fn, items))
    docs = {}
    for w in (1, 2):
        run_config(config, out_dir=tmp_path / f"out{w}", workers=w, progress=False,
                   created="2026-01-01T00:00:00+00:00")
        docs[w] = json.loads((tmp_path / f"out{w}" / "results.json").read_text())
    assert calls and calls[0] == 8  # the 8 events' fits, in 8 chunks (two workers)

    def strip(x):
        if isinstance(x, dict):
            return {k: strip(v) for k, v in x.items() if k not in ("seconds", "time")}
        return [strip(v) for v in x] if isinstance(x, list) else x
    assert strip(docs[2]) == strip(docs[1])
