"""A run waiting for another run's history lock stops at once on SIGTERM (issue 31): the
history's lock is taken before the run holds the signals to publish, as the folder's
lock is, so the wait (up to two minutes) is never spent deaf. Nothing is published by
the stopped run; once the lock is free, the same run writes its report and its row."""

from __future__ import annotations

import os
import select
import signal
import subprocess
import sys
import textwrap
import time

import polars as pl
from filelock import FileLock

from tests.test_cli import _config, _csv

#: The command in a process of its own, saying on stderr when it starts to wait for the
#: history's lock (the real lock, taken right after).
CHILD = textwrap.dedent("""
    import sys
    from contextlib import contextmanager
    import pipeline.run as run
    real = run.history_lock

    @contextmanager
    def announced(*args):
        print("waiting for the history lock", file=sys.stderr, flush=True)
        with real(*args):
            yield

    run.history_lock = announced
    sys.argv = ["pipeline", *sys.argv[1:]]
    from pipeline.__main__ import main
    main()
""")


def _start(tmp_path, out, history):
    p = _csv(tmp_path)
    c = _config(tmp_path, f"name: t\ndata:\n  path: {p.name}\n  input: u\n  output: y\n"
                "  time: time\nmethods: [first_order]\n")
    env = {**os.environ, "MPLBACKEND": "Agg"}
    return subprocess.Popen([sys.executable, "-c", CHILD, "run", str(c), "--out", str(out),
                             "--workers", "1", "--history", str(history)],
                            stderr=subprocess.PIPE, stdout=subprocess.DEVNULL, text=True,
                            env=env)


def _wait_for(proc, text: str, timeout: float = 120.0) -> None:
    """Read the child's stderr until ``text``, for at most ``timeout`` seconds (a child
    that hangs without writing fails the test, it does not hang it)."""
    end = time.monotonic() + timeout
    while (left := end - time.monotonic()) > 0:
        if not select.select([proc.stderr], [], [], left)[0]:
            break
        line = proc.stderr.readline()
        if text in line:
            return
        if not line and proc.poll() is not None:
            raise AssertionError(f"the run ended ({proc.returncode}) before {text!r}")
    raise AssertionError(f"no {text!r} within {timeout} s")


def test_sigterm_while_waiting_for_the_history_lock(tmp_path):
    out, history = tmp_path / "out", tmp_path / "h" / "history.parquet"
    history.parent.mkdir()
    with FileLock(str(history.parent / "history.parquet.lock")):  # another run's append
        proc = _start(tmp_path, out, history)
        try:
            _wait_for(proc, "waiting for the history lock")
            time.sleep(0.5)
            t0 = time.monotonic()
            proc.send_signal(signal.SIGTERM)
            _, err = proc.communicate(timeout=30)
            code, waited = proc.returncode, time.monotonic() - t0
        finally:
            proc.kill()
    assert code == 128 + signal.SIGTERM, err
    assert waited < 10.0  # not the lock's two minutes
    assert "Traceback" not in err
    assert not (out / "results.json").exists() and not history.exists()


def test_the_same_run_goes_through_once_the_lock_is_free(tmp_path):
    """The stay-ok twin: the lock held for a while, then released; the run waits for
    it, then publishes its report and writes its row."""
    out, history = tmp_path / "out", tmp_path / "h" / "history.parquet"
    history.parent.mkdir()
    lock = FileLock(str(history.parent / "history.parquet.lock"))
    lock.acquire()
    proc = _start(tmp_path, out, history)
    try:
        _wait_for(proc, "waiting for the history lock")
        time.sleep(0.5)
        assert not (out / "results.json").exists()  # it waits before publishing
        lock.release()
        _, err = proc.communicate(timeout=120)  # (reads stderr: a full pipe never stalls it)
        assert proc.returncode == 0, err
    finally:
        proc.kill()
        if lock.is_locked:
            lock.release()
    assert (out / "results.json").exists() and (out / "report.html").exists()
    assert pl.read_parquet(history).height >= 1


def test_a_history_held_too_long_says_nothing_was_written(tmp_path, monkeypatch):
    """The lock is taken before anything is published, so its timeout says that the run
    wrote nothing (not only that its rows are missing), and leaves no report."""
    from typer.testing import CliRunner

    from pipeline.cli.commands import app
    from pipeline.gate import history as hist

    p = _csv(tmp_path)
    c = _config(tmp_path, f"name: t\ndata:\n  path: {p.name}\n  input: u\n  output: y\n"
                "  time: time\nmethods: [first_order]\n")
    out, history = tmp_path / "out", tmp_path / "history.parquet"
    monkeypatch.setattr(hist, "LOCK_WAIT", 0.3)
    with FileLock(str(tmp_path / "history.parquet.lock")):
        r = CliRunner().invoke(app, ["run", str(c), "--out", str(out), "--workers", "1",
                                     "--history", str(history)])
    assert r.exit_code == 2, r.output
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and "another run has held the history" in lines[0]
    assert "nothing of this run was written" in lines[0]
    assert not (out / "results.json").exists() and not history.exists()
