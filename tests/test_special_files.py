"""Devices and pipes where a file is expected (issue 31): ``--baseline /dev/zero`` read
until the memory ran out (killed), a FIFO as the baseline, the config or the history hung
the run forever, and ``--junit /dev/null`` would have replaced the device with a file.
Each is now one line naming the path and what it is, exit 2, nothing written; the
stay-ok twin runs the same command with regular files. Real processes with a timeout, so
a regression fails instead of hanging the suite."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from tests.test_cli import _csv

pytestmark = pytest.mark.skipif(not hasattr(os, "mkfifo") or not Path("/dev/zero").exists(),
                                reason="needs FIFOs and /dev/zero")


def _run(folder: Path, *args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "pipeline", *args], cwd=folder,
                          capture_output=True, text=True, timeout=120)


@pytest.fixture
def case(tmp_path):
    _csv(tmp_path)
    (tmp_path / "c.yaml").write_text("name: c\ndata:\n  path: log.csv\n  input: u\n"
                                     "  output: y\n  time: time\nmethods: [first_order]\n")
    os.mkfifo(tmp_path / "fifo")
    return tmp_path


@pytest.mark.parametrize("args, says", [
    (("run", "c.yaml", "--out", "out", "--baseline", "/dev/zero"),
     "/dev/zero: a device, not a regular file; expected the results file"),
    (("run", "c.yaml", "--out", "out", "--baseline", "fifo"),
     "fifo: a pipe, not a regular file; expected the results file"),
    (("run", "fifo", "--out", "out"),
     "fifo: a pipe, not a regular file; expected the config file"),
    (("run", "c.yaml", "--out", "out", "--history", "fifo"),
     "fifo: a pipe, not a regular file; cannot write the history there"),
    (("run", "c.yaml", "--out", "out", "--junit", "fifo"),
     "fifo: a pipe, not a regular file; cannot write the JUnit file there"),
    (("run", "c.yaml", "--out", "out", "--junit", "/dev/null"),
     "/dev/null: a device, not a regular file; cannot write the JUnit file there"),
])
def test_a_device_or_pipe_is_refused_in_one_line(case, args, says):
    r = _run(case, *args)
    assert r.returncode == 2, r.stderr
    assert r.stderr == f"error: {says}\n", r.stderr
    assert not (case / "out").exists()
    assert Path("/dev/null").is_char_device()


def test_the_same_run_with_regular_files_goes_on(case):
    r = _run(case, "run", "c.yaml", "--out", "out", "--history", "h.parquet",
             "--junit", "j.xml")
    assert r.returncode == 0, r.stderr
    r = _run(case, "run", "c.yaml", "--out", "out2", "--baseline", "out/results.json",
             "--history", "h.parquet")
    assert r.returncode == 0, r.stderr
    assert (case / "j.xml").is_file() and (case / "out2" / "report.html").is_file()
