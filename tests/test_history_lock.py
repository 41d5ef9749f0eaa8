"""Concurrent history appends lose nothing (issue 31): four processes appending ten runs
each to one history keep all forty; a lock another run holds too long is one line."""

from __future__ import annotations

import subprocess
import sys
import textwrap

import pytest
from typer.testing import CliRunner

from pipeline.cli.commands import app
from pipeline.errors import UserError
from pipeline.gate import history as hist
from pipeline.gate.baseline_file import load_results
from tests.test_cli import _csv

APPEND = textwrap.dedent("""
    import sys
    from datetime import UTC, datetime, timedelta
    from pipeline.gate.baseline_file import load_results
    from pipeline.gate.history import append_history
    doc = load_results(sys.argv[1])
    k = int(sys.argv[3])
    for i in range(10):
        append_history(sys.argv[2], doc, datetime(2026, 1, 1, tzinfo=UTC)
                       + timedelta(minutes=100 * k + i))
""")


@pytest.fixture(scope="module")
def results(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("lock")
    log = _csv(tmp, "log.csv")
    r = CliRunner().invoke(app, ["identify", str(log), "--input", "u", "--output", "y",
                                 "--time", "time", "--method", "first_order", "--out",
                                 str(tmp / "out")])
    assert r.exit_code == 0, r.output
    return tmp / "out" / "results.json"


def test_four_processes_appending_keep_every_row(results, tmp_path):
    path = tmp_path / "h" / "history.parquet"
    per_run = hist.history_rows(load_results(results), None).height
    procs = [subprocess.Popen([sys.executable, "-c", APPEND, str(results), str(path),
                               str(k)]) for k in range(4)]
    assert all(p.wait(timeout=240) == 0 for p in procs)
    frame = hist.load_history(path)
    assert frame.height == 40 * per_run
    assert frame["time"].n_unique() == 40


def test_a_lock_held_too_long_is_one_line(results, tmp_path, monkeypatch):
    from filelock import FileLock

    path = tmp_path / "history.parquet"
    monkeypatch.setattr(hist, "LOCK_WAIT", 0.2)
    with FileLock(str(tmp_path / "history.parquet.lock")):
        with pytest.raises(UserError, match="another run has held the history"):
            hist.append_history(path, load_results(results))
    assert not path.exists()
    hist.append_history(path, load_results(results))  # released: the append goes in
    assert path.exists()
