"""Batch execution: in-process, local process pool and Dask give the same results, in order."""

from __future__ import annotations

import sys

import pytest

from pipeline.batch.pool import crashed, pool_context, resolve_workers, run_records
from pipeline.batch.progress import is_failure
from pipeline.config import config_from_dict
from pipeline.errors import UserError
from pipeline.results import RecordResult, results_json
from pipeline.run import RecordSpec, process_record, resolve_specs
from pipeline.synth.logs import plan_logs, write_synthetic_logs

N = 6
CORRUPT = 1


@pytest.fixture(scope="module")
def batch(tmp_path_factory):
    folder = tmp_path_factory.mktemp("logs")
    write_synthetic_logs(folder, N, seed=21, corrupt=CORRUPT, n_steps=2)
    cfg = config_from_dict({"data": {"path": str(folder), "input": "u", "output": "y",
                                     "time": "time"},
                            "methods": ["first_order", "viteckova1", "latzel"]},
                           base_dir=str(folder))
    specs = resolve_specs(cfg)
    return specs, cfg


@pytest.fixture(scope="module")
def inline(batch):
    specs, cfg = batch
    return run_records(specs, cfg, process_record, workers=1, progress=False)


def assert_same(a: list[RecordResult], b: list[RecordResult]) -> None:
    """Same records in the same order, parameters equal to 1e-12, everything else equal."""
    assert [r.name for r in a] == [r.name for r in b]
    for ra, rb in zip(a, b, strict=True):
        da, db = ra.to_doc(), rb.to_doc()
        for fa, fb in zip(da.fits, db.fits, strict=True):
            assert (fa.method, fa.status) == (fb.method, fb.status)
            for k, v in (fa.params or {}).items():
                assert fb.params[k] == pytest.approx(v, rel=1e-12, abs=1e-12)
        assert da.model_dump_json() == db.model_dump_json()


def test_inline_results_in_order_with_the_failure(batch, inline):
    specs, _ = batch
    assert [r.name for r in inline] == [s.name for s in specs]
    bad = {p.name for p in plan_logs(N, seed=21, corrupt=CORRUPT) if p.corruption}
    assert {r.name for r in inline if not r.ok} == bad
    assert all(r.fits and r.fits[0].ok for r in inline if r.ok)


def test_local_pool_equals_in_process(batch, inline):
    specs, cfg = batch
    assert_same(run_records(specs, cfg, process_record, workers=2, progress=False), inline)


def test_dask_cluster_equals_local(batch, inline):
    distributed = pytest.importorskip("distributed")
    import dask

    specs, cfg = batch
    # workers forked from the fork server that has pipeline imported (see pool_context)
    pool_context()
    with dask.config.set({"distributed.worker.multiprocessing-method": "forkserver"}), \
            distributed.LocalCluster(n_workers=2, processes=True, threads_per_worker=1,
                                     dashboard_address=None) as cluster:
        result = run_records(specs, cfg, process_record, executor="dask",
                             scheduler=cluster.scheduler_address, progress=False)
    assert_same(result, inline)


def test_progress_bar_only_when_asked(batch, capsys):
    specs, cfg = batch
    run_records(specs[:3], cfg, process_record, workers=1, progress=True)
    err = capsys.readouterr().err
    assert "records" in err and "3/3" in err and "failures:" in err
    run_records(specs[:2], cfg, process_record, workers=1)  # stdout: not a terminal here
    captured = capsys.readouterr()
    assert captured.err == "" and captured.out == ""


def flaky_job(spec: RecordSpec, cfg):
    """A job that breaks its contract for one record."""
    if spec.name.endswith("1"):
        raise RuntimeError("boom\nsecond line")
    return process_record(spec, cfg)


@pytest.mark.parametrize("workers", [1, 2])
def test_a_raising_job_fails_only_its_record(batch, workers):
    specs, cfg = batch
    out = run_records(specs[:3], cfg, flaky_job, workers=workers, progress=False)
    assert [r.name for r in out] == [s.name for s in specs[:3]]
    assert [is_failure(r) for r in out] == [False, True, False]
    assert out[1].error.endswith("processing crashed (RuntimeError: boom second line)")


def test_argument_errors(batch, monkeypatch):
    specs, cfg = batch
    with pytest.raises(UserError, match="unknown executor"):
        run_records(specs, cfg, process_record, executor="spark")
    with pytest.raises(UserError, match="at least 1"):
        run_records(specs, cfg, process_record, workers=0)
    assert run_records([], cfg, process_record) == []
    assert resolve_workers(8, 3) == 3 and resolve_workers(None, 1) == 1
    monkeypatch.setitem(sys.modules, "distributed", None)  # as if not installed
    with pytest.raises(UserError, match=r"pip install \.\[dask\]"):
        run_records(specs, cfg, process_record, executor="dask", scheduler="tcp://127.0.0.1:8786")


def test_crashed_and_is_failure():
    spec = RecordSpec("a", "a.csv")
    res = crashed(spec, ValueError("x"))
    assert res.error == "a.csv: processing crashed (ValueError: x)" and is_failure(res)
    assert '"status": "failed"' in results_json(
        __import__("pipeline.results").results.RunResult([res]).to_doc())
    assert crashed("plain", KeyError("k")).name == "plain"


@pytest.mark.parametrize("answer", [b"", b"HTTP/1.0 200 OK\r\n\r\n" + b"\xff" * 64])
def test_a_port_that_never_answers_as_a_scheduler_is_one_error(answer):
    """A port that accepts and stays silent (or answers something else) is a UserError
    within the timeout, not a wait for ever (issue 31: still running at 100 s)."""
    import socket
    import threading
    import time

    from distributed import Client

    from pipeline.batch.cluster import connect

    server = socket.socket()
    server.bind(("127.0.0.1", 0))
    server.listen(4)
    held = []

    def serve():
        while True:
            try:
                conn, _ = server.accept()
            except OSError:
                return
            held.append(conn)
            if answer:
                conn.sendall(answer)
    threading.Thread(target=serve, daemon=True).start()
    t0 = time.monotonic()
    try:
        with pytest.raises(UserError, match="cannot reach the Dask scheduler at tcp://127"):
            connect(Client, f"tcp://127.0.0.1:{server.getsockname()[1]}", timeout=1.0)
    finally:
        server.close()
        for c in held:
            c.close()
    assert time.monotonic() - t0 < 10
