"""``--executor dask`` against a scheduler and a worker started as separate processes in
another working directory (issue 13 item 17): a config with relative paths gives the same
results as the local executor, because the client makes every path absolute."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from pathlib import Path

import pytest

from pipeline.run import run_config
from pipeline.synth.logs import write_synthetic_logs
from tests.test_batch import assert_same

pytest.importorskip("distributed")

ROOT = Path(__file__).resolve().parents[1]


def _start(module: str, args: list[str], cwd: Path) -> subprocess.Popen:
    env = {**os.environ, "PYTHONPATH": str(ROOT), "DASK_DISTRIBUTED__WORKER__DAEMON": "False"}
    return subprocess.Popen([sys.executable, "-m", module, *args], cwd=cwd, env=env,
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)


def _address(scheduler_file: Path, proc: subprocess.Popen, timeout: float = 60) -> str:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline and proc.poll() is None:
        try:
            return json.loads(scheduler_file.read_text())["address"]
        except (OSError, ValueError, KeyError):
            time.sleep(0.1)
    pytest.fail(f"the Dask scheduler did not start (exit code {proc.poll()})")


def test_dask_workers_elsewhere_read_relative_paths(tmp_path, monkeypatch):
    project, elsewhere = tmp_path / "project", tmp_path / "elsewhere"
    elsewhere.mkdir()
    write_synthetic_logs(project / "logs", 3, seed=17, n_steps=2)
    (project / "night.yaml").write_text(
        "name: night\ndata:\n  path: logs\n  input: u\n  output: y\n  time: time\n"
        "methods: [first_order, viteckova1]\nreport: {plots: none}\n")
    scheduler_file = elsewhere / "scheduler.json"
    procs = [_start("distributed.cli.dask_scheduler",
                    ["--host", "127.0.0.1", "--port", "0", "--no-dashboard",
                     "--scheduler-file", str(scheduler_file)], elsewhere)]
    try:
        address = _address(scheduler_file, procs[0])
        procs.append(_start("distributed.cli.dask_worker",
                            ["--scheduler-file", str(scheduler_file), "--host", "127.0.0.1",
                             "--no-dashboard", "--nworkers", "1", "--nthreads", "1"],
                            elsewhere))
        monkeypatch.chdir(project)  # the config and its data named relative to here
        remote = run_config("night.yaml", executor="dask", scheduler=address,
                            out_dir=tmp_path / "dask", progress=False)
        local = run_config("night.yaml", workers=1, out_dir=tmp_path / "local",
                           progress=False)
    finally:
        for p in reversed(procs):
            p.terminate()
        for p in procs:
            try:
                p.wait(10)
            except subprocess.TimeoutExpired:
                p.kill()
                p.wait(5)
    assert [r.error for r in remote.run.records] == [None] * 3
    assert remote.exit_code == local.exit_code == 0
    assert_same(remote.run.records, local.run.records)
