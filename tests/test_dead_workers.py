"""A pool worker that dies (what the OOM killer does, issue 31): the record it held is run
again in a worker of its own, only a record that kills that one too fails, every other
record and the report go on; a worker dying while the report's plots are drawn costs
nothing but time."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from pipeline.batch import pool as pool_module
from pipeline.batch.pool import local_pool, parallel_map, run_records
from pipeline.config import config_from_dict
from pipeline.run import process_record, resolve_specs
from pipeline.synth.logs import write_synthetic_logs

ROOT = Path(__file__).resolve().parents[1]
N = 6


@pytest.fixture(scope="module")
def batch(tmp_path_factory):
    folder = tmp_path_factory.mktemp("dying")
    write_synthetic_logs(folder, N, seed=5, n_steps=2)
    cfg = config_from_dict({"data": {"path": str(folder), "input": "u", "output": "y",
                                     "time": "time"},
                            "methods": ["first_order", "viteckova1"]}, base_dir=str(folder))
    return resolve_specs(cfg), cfg, folder


def dying_job(spec, cfg):
    """process_record, except that the records named in ``cfg`` kill the worker process
    that runs them: always (``always``), or the first time only (``once``, a marker file
    says it happened)."""
    real, parent, always, once, marker = cfg
    if os.getpid() != parent:
        if spec.name in always:
            os._exit(137)
        if spec.name in once and not marker.exists():
            marker.write_text("died once")
            os.kill(os.getpid(), signal.SIGKILL)
    return process_record(spec, real)


@pytest.mark.parametrize("case", ["always", "once"])
def test_a_record_that_kills_its_worker_fails_alone(batch, tmp_path, monkeypatch, case):
    """``always``: the record fails, with the reason, and only it; ``once``: its second
    worker lives, and every record comes back whole."""
    specs, cfg, _ = batch
    warned = []
    monkeypatch.setattr(pool_module.log, "warning", lambda *a: warned.append(a))
    victim = specs[0].name  # the first sent to the pool (the parent takes the last ones)
    plain = run_records(specs, cfg, process_record, workers=1, progress=False)
    got = run_records(specs, (cfg, os.getpid(), {victim} if case == "always" else set(),
                              {victim} if case == "once" else set(), tmp_path / "marker"),
                      dying_job, workers=2, progress=False)
    assert [r.name for r in got] == [s.name for s in specs]  # in order, every record
    for r, p in zip(got, plain, strict=True):
        if r.name == victim and case == "always":
            assert r.error and "worker process died" in r.error and victim in r.error
        else:
            assert r.error is None
            assert r.recommended.model.params == p.recommended.model.params
    assert (tmp_path / "marker").exists() == (case == "once")  # it did kill a worker
    assert warned and "run again" in warned[0][0]
    assert len(warned) == 1  # one death: the fresh pool for the rest lived


def test_no_death_no_isolation(batch, monkeypatch):
    """The twin: a batch whose workers live never runs a record twice."""
    specs, cfg, _ = batch
    called = []
    monkeypatch.setattr(pool_module, "_run_isolated", lambda *a: called.append(a))
    got = run_records(specs, cfg, process_record, workers=2, progress=False)
    assert called == [] and all(r.error is None for r in got)


def double_or_die(x: tuple[int, int]) -> int:
    parent, value = x
    if os.getpid() != parent and value == 0:  # the first sent: never taken here
        os._exit(137)
    return 2 * value


def test_report_map_survives_a_dead_worker(monkeypatch):
    warned = []
    monkeypatch.setattr(pool_module.log, "warning", lambda *a: warned.append(a))
    items = [(os.getpid(), k) for k in range(12)]
    with local_pool(2, 12) as pool:
        with parallel_map(pool, len(items)) as mapper:
            assert list(mapper(double_or_die, items)) == [2 * k for k in range(12)]
        assert warned and pool_module.is_broken(pool)
        with parallel_map(pool, len(items)) as mapper:  # broken: this process maps
            assert mapper is map


def parents() -> dict[int, int]:
    """pid -> parent pid of every live process (``/proc/PID/stat``)."""
    out = {}
    for d in Path("/proc").iterdir():
        if d.name.isdigit():
            try:
                fields = (d / "stat").read_text().rsplit(")", 1)[1].split()
            except OSError:
                continue
            if fields[0] not in "ZX":
                out[int(d.name)] = int(fields[1])
    return out


def worker_pids(cli_pid: int) -> list[int]:
    """The pool workers of a ``pipeline run`` process: its children's children (the fork
    server's; the resource tracker has none)."""
    ppid = parents()
    helpers = {p for p, pp in ppid.items() if pp == cli_pid}
    return sorted(p for p, pp in ppid.items() if pp in helpers)


@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="needs /proc")
def test_killing_a_worker_of_a_nightly_run_keeps_the_report(tmp_path):
    """SIGKILL to one worker in the middle of a real ``pipeline run``: exit 0, every record
    analysed, the report written, one warning line."""
    write_synthetic_logs(tmp_path / "logs", 16, seed=9, n_steps=6)
    cfg = tmp_path / "night.yaml"
    cfg.write_text("name: night\ndata:\n  path: logs\n  input: u\n  output: y\n  time: time\n"
                   "report: {plots: summary}\n")
    env = {**os.environ, "PYTHONPATH": str(ROOT), "MPLBACKEND": "Agg"}
    proc = subprocess.Popen([sys.executable, "-m", "pipeline", "run", str(cfg), "--workers",
                             "2", "--out", str(tmp_path / "out")], cwd=tmp_path, env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    deadline, killed = time.monotonic() + 60, None
    while killed is None and time.monotonic() < deadline and proc.poll() is None:
        pids = worker_pids(proc.pid)
        if len(pids) >= 2:
            time.sleep(0.5)  # both busy with records by now
            killed = pids[0]
            os.kill(killed, signal.SIGKILL)
        time.sleep(0.05)
    out, err = proc.communicate(timeout=180)
    assert killed is not None, "the run ended before its workers could be seen"
    assert proc.returncode == 0, err.decode()
    doc = json.loads((tmp_path / "out" / "results.json").read_text())
    assert len(doc["records"]) == 16 and all(r.get("error") is None for r in doc["records"])
    assert (tmp_path / "out" / "report.html").exists()
    assert b"Traceback" not in err
