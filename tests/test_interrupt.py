"""Interrupted runs (issue 13 item 8): SIGTERM at random points of a 2-worker batch, and a
SIGKILL, leave no live process, no temporary folder, the previous report intact, and the
caller's pipes closed (``out=$(pipeline run ...)`` returns)."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from pipeline.run import run_config
from pipeline.synth.logs import write_synthetic_logs

pytestmark = pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="needs /proc")

ROOT = Path(__file__).resolve().parents[1]
TRIES = 10
GRACE = 5.0  # s after the CLI ends: no process of its session may still run


def session_alive(sid: int) -> list[str]:
    """Live (not zombie) processes of session ``sid``: ``"pid cmdline"`` each."""
    alive = []
    for d in Path("/proc").iterdir():
        if not d.name.isdigit():
            continue
        try:
            stat = (d / "stat").read_text()
            cmd = (d / "cmdline").read_bytes().replace(b"\0", b" ").decode(errors="replace")
        except OSError:
            continue
        fields = stat.rsplit(")", 1)[1].split()  # state ppid pgrp session ...
        if int(fields[3]) == sid and fields[0] not in "ZX":
            alive.append(f"{d.name} {cmd[:80]}")
    return alive


def wait_gone(sid: int) -> list[str]:
    deadline = time.monotonic() + GRACE
    while (alive := session_alive(sid)) and time.monotonic() < deadline:
        time.sleep(0.1)
    return alive


def snapshot(folder: Path) -> dict[str, bytes]:
    return {p.relative_to(folder).as_posix(): p.read_bytes()
            for p in sorted(folder.rglob("*")) if p.is_file()}


@pytest.fixture(scope="module")
def nightly(tmp_path_factory):
    d = tmp_path_factory.mktemp("interrupt")
    write_synthetic_logs(d / "logs", 6, seed=8, n_steps=2)
    cfg = d / "night.yaml"
    cfg.write_text("name: night\ndata:\n  path: logs\n  input: u\n  output: y\n  time: time\n"
                   "methods: [first_order, viteckova1, latzel]\nreport: {plots: none}\n")
    out = d / "reports" / "night"
    assert run_config(cfg, out_dir=out, workers=1, progress=False).exit_code == 0
    return d, cfg, out


def start(d: Path, cfg: Path, out: Path) -> subprocess.Popen:
    env = {**os.environ, "PYTHONPATH": str(ROOT), "MPLBACKEND": "Agg"}
    return subprocess.Popen(
        [sys.executable, "-m", "pipeline", "run", str(cfg), "--workers", "2", "--out",
         str(out)], cwd=d, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
        start_new_session=True)


def _unchanged_or_complete(before: dict, after: dict, delay: float) -> dict:
    """The outputs are the old ones, or a complete new report: every file replaced, the
    results of all six records (never a mix of old and new, never a part)."""
    if after == before:
        return before
    changed = {k for k in after if after[k] != before.get(k)}
    assert after.keys() == before.keys(), f"delay {delay:.2f} s"
    assert {"results.json", "report.md", "report.html"} <= changed, (delay, changed)
    assert len(json.loads(after["results.json"])["records"]) == 6
    return after


def test_sigterm_at_random_points_leaves_nothing_behind(nightly):
    d, cfg, out = nightly
    # the points are drawn over the length of a whole run measured here, now: under a
    # loaded CI host the imports before the handler alone took longer than a fixed 2.5 s
    # (seen: 0 of 10 signals inside the run). The shorter of two runs: the first is cold
    # (7.4 s once, where the runs after it took under 6 s, so that 6 of 10 points fell
    # after their end)
    runs = []
    for _ in range(2):
        began = time.monotonic()
        whole_run = start(d, cfg, out)
        whole_run.communicate(timeout=120)
        assert whole_run.returncode == 0
        runs.append(time.monotonic() - began)
    whole = min(runs)
    before = snapshot(out)
    delays = np.random.default_rng(13).uniform(0.3, 0.9, TRIES) * whole
    interrupted = 0
    codes = []
    for delay in delays:
        proc = start(d, cfg, out)
        time.sleep(delay)
        proc.send_signal(signal.SIGTERM)
        # communicate() returns only when every holder of the pipes is gone
        stdout, stderr = proc.communicate(timeout=30)
        err = stderr.decode()
        codes.append((round(float(delay), 2), proc.returncode))
        assert wait_gone(proc.pid) == [], f"delay {delay:.2f} s"
        assert sorted(p.name for p in out.parent.iterdir()) == ["night"], f"delay {delay:.2f}"
        if proc.returncode == -signal.SIGTERM:
            # no handler: before it was installed (nothing had started), or after it was
            # removed at the end of a run that had published everything
            before = _unchanged_or_complete(before, snapshot(out), delay)
        elif proc.returncode == 128 + signal.SIGTERM:
            interrupted += 1
            assert "interrupted by SIGTERM" in err and "Traceback" not in err, err
            # the signal may have come while the new report was put in place: all of it
            before = _unchanged_or_complete(before, snapshot(out), delay)
        else:  # the run had finished: a complete new report
            assert proc.returncode == 0, (delay, proc.returncode, err)
            assert b"6 of 6 record(s)" in stdout
            after = snapshot(out)
            assert after.keys() == before.keys()
            assert len(json.loads(after["results.json"])["records"]) == 6
            before = after
    # the random points mostly fall inside the run
    assert interrupted >= TRIES // 2, (f"whole run {whole:.2f} s", codes)


def test_sigkill_takes_the_workers_with_it(nightly):
    d, cfg, out = nightly
    proc = start(d, cfg, out)
    deadline = time.monotonic() + 20
    # CLI, resource tracker, fork server and at least one worker
    while len(session_alive(proc.pid)) < 4 and time.monotonic() < deadline:
        time.sleep(0.05)
    assert len(session_alive(proc.pid)) >= 4, session_alive(proc.pid)
    proc.kill()
    proc.communicate(timeout=30)  # the pipes close: no helper holds them
    assert wait_gone(proc.pid) == []


def test_a_signal_that_arrives_wrapped_still_stops_cleanly():
    """A SIGTERM inside an import reaches us as ``RuntimeError: Error calling __set_name__``
    with the Interrupted as its context (seen in CI): still exit 143 with one line."""
    import typer

    from pipeline.batch.interrupt import Interrupted, interruption
    from pipeline.cli.commands import stoppable

    def wrapped():
        try:
            raise Interrupted(signal.SIGTERM)
        except Interrupted:
            raise RuntimeError("Error calling __set_name__ on 'cached_property'") from None

    try:
        wrapped()
    except RuntimeError as exc:
        assert interruption(exc) is not None and interruption(exc).signum == signal.SIGTERM
        assert interruption(ValueError("x")) is None
    with pytest.raises(typer.Exit) as stop:
        stoppable(wrapped)()
    assert stop.value.exit_code == 128 + signal.SIGTERM
    with pytest.raises(ValueError):  # anything else is not ours to swallow
        stoppable(lambda: (_ for _ in ()).throw(ValueError("x")))()
