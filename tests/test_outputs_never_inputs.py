"""An output never replaces an input of the same run (issue 31): ``--junit`` or
``--history`` naming the config, a log, the baseline or each other is refused in one
line before the batch, and an existing file that is not a JUnit file we wrote is never
overwritten; the user's files stay byte-equal. A JUnit file of an earlier run is still
replaced (the must-stay-working twin)."""

from __future__ import annotations

import os

import pytest
from typer.testing import CliRunner

from pipeline.cli.commands import app
from tests.test_cli import _csv

runner = CliRunner()


@pytest.fixture
def setup(tmp_path):
    log = _csv(tmp_path, "log.csv")
    cfg = tmp_path / "c.yaml"
    cfg.write_text(f"name: x\ndata:\n  path: {log}\n  input: u\n  output: y\n  time: time\n"
                   "methods: [first_order]\nreport: {plots: none}\n")
    return tmp_path, cfg, log


def _refused(args, *files):
    before = {f: f.read_bytes() for f in files}
    r = runner.invoke(app, args)
    assert r.exit_code == 2, r.output
    (line,) = r.stderr.strip().splitlines()
    assert "Traceback" not in r.output
    assert all(f.read_bytes() == b for f, b in before.items())
    return line


@pytest.mark.parametrize("which", ["config", "log", "link"])
def test_junit_onto_an_input_is_refused(setup, which):
    tmp, cfg, log = setup
    target = {"config": cfg, "log": log, "link": tmp / "link.xml"}[which]
    if which == "link":
        os.symlink(cfg, target)
    line = _refused(["run", str(cfg), "--out", str(tmp / "out"), "--junit", str(target)],
                    cfg, log)
    assert "would replace" in line and ("the config" in line)  == (which != "log")
    assert not (tmp / "out").exists()


def test_history_onto_junit_and_a_foreign_file_are_refused(setup):
    tmp, cfg, log = setup
    both = tmp / "same.out"
    line = _refused(["run", str(cfg), "--out", str(tmp / "o"), "--junit", str(both),
                     "--history", str(both)], cfg)
    assert "would replace" in line
    notes = tmp / "notes.xml"
    notes.write_text("<notes>mine</notes>\n")
    line = _refused(["run", str(cfg), "--out", str(tmp / "o"), "--junit", str(notes)], notes)
    assert "is not a JUnit file pipeline wrote" in line


def test_a_junit_file_of_an_earlier_run_is_replaced(setup):
    tmp, cfg, _ = setup
    junit = tmp / "junit.xml"
    for _ in range(2):
        r = runner.invoke(app, ["run", str(cfg), "--out", str(tmp / "o"), "--junit",
                                str(junit)])
        assert r.exit_code == 0, r.output
    assert junit.read_text().count("<testsuites") == 1


def test_junit_and_history_links_are_written_through(setup):
    """Issue 31: a --history or --junit symlink to a shared file was replaced by a regular
    file, so the shared file never got the row. The links stay links; their targets get
    the writes (the history: one row set per run, twice)."""
    from pipeline.gate.history import load_history

    tmp, cfg, _ = setup
    shared = tmp / "shared"
    shared.mkdir()
    (tmp / "junit.xml").symlink_to(shared / "junit.xml")  # dangling until the first run
    (tmp / "history.parquet").symlink_to(shared / "history.parquet")
    for night in range(2):
        r = runner.invoke(app, ["run", str(cfg), "--out", str(tmp / f"o{night}"), "--junit",
                                str(tmp / "junit.xml"), "--history",
                                str(tmp / "history.parquet")])
        assert r.exit_code == 0, r.output
    assert (tmp / "junit.xml").is_symlink() and (tmp / "history.parquet").is_symlink()
    assert "<testsuites" in (shared / "junit.xml").read_text()
    assert load_history(shared / "history.parquet")["time"].n_unique() == 2


def test_a_link_loop_and_a_fifo_are_refused(setup):
    tmp, cfg, _ = setup
    (tmp / "a.xml").symlink_to(tmp / "b.xml")
    (tmp / "b.xml").symlink_to(tmp / "a.xml")
    line = _refused(["run", str(cfg), "--out", str(tmp / "o"), "--junit", str(tmp / "a.xml")])
    assert "loop of symbolic links" in line
    os.mkfifo(tmp / "fifo")
    line = _refused(["run", str(cfg), "--out", str(tmp / "o"), "--junit", str(tmp / "fifo")])
    assert "not a regular file" in line
