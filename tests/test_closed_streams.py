"""A command started with stdout or stderr closed (``>&-``, ``2>&-``; issue 31): a closed
stdout was an AttributeError traceback (``--json``) or a silent exit 0 with the output
lost; now each write to it is one line and exit 2. The closed descriptor is held on
/dev/null first, so no file the command opens takes its number (and what is written to
the stream never lands in a report)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from tests.corpus import step_csv

ROOT = Path(__file__).resolve().parents[1]
ARGS = "--input u --output y --time time --method first_order"


def sh(command: str, cwd: Path) -> subprocess.CompletedProcess:
    env = {**os.environ, "PYTHONPATH": str(ROOT), "MPLBACKEND": "Agg"}
    return subprocess.run(["sh", "-c", f"exec {sys.executable} -m pipeline {command}"],
                          cwd=cwd, env=env, capture_output=True, text=True, timeout=120)


@pytest.fixture()
def log(tmp_path):
    (tmp_path / "log.csv").write_text(step_csv())
    return tmp_path


@pytest.mark.parametrize("command", [f"identify log.csv {ARGS} --json", "methods"])
def test_a_closed_stdout_is_one_line(log, command):
    res = sh(f"{command} >&-", log)
    lines = [x for x in res.stderr.splitlines() if x.strip()]
    assert res.returncode == 2 and len(lines) == 1, res.stderr
    assert "cannot write standard output: it is closed" in lines[0]
    assert sh(f"{command} > out.txt", log).returncode == 0  # the twin: a file takes it
    assert (log / "out.txt").stat().st_size > 0


def test_files_the_command_writes_never_get_the_closed_number(log):
    res = sh(f"identify log.csv {ARGS} --out res >&-", log)
    assert res.returncode == 2  # the ranking had nowhere to go
    doc = json.loads((log / "res" / "results.json").read_text())  # whole, nothing mixed in
    assert doc["records"][0]["fits"]
    assert (log / "res" / "report.md").read_text().startswith("#")


def test_a_closed_stderr_keeps_the_exit_code(log):
    assert sh(f"identify nope.csv {ARGS} 2>&-", log).returncode == 2
    assert sh(f"identify log.csv {ARGS} -q 2>&-", log).returncode == 0
