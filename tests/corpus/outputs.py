"""Corpus rows for the output folder and failing batches (issue 13 items 2, 3, 9, 11, 12):
the user's files in ``--out`` kept, ``name`` never a path, stale staging of a killed run
removed, a bad target one line, an all-failed batch still reported."""

from __future__ import annotations

import json
import xml.etree.ElementTree as ET
from pathlib import Path

from pipeline.config import folder_name
from pipeline.report.outdir import STAGING, host_tag
from tests.corpus import Hostile, config, step_csv

LOG = step_csv()
# one overview plot a record (rendering plots is most of a row's time)
GOOD = config("path: log.csv\ninput: u\noutput: y\ntime: time",
              extra="report: {plots: summary}\n")
NOPLOTS = GOOD.replace("plots: summary", "plots: none")
BAD = config("path: bad.csv\ninput: u\noutput: y\ntime: time")
SHORT = "time,u,y\n0,0,0\n1,1,0\n"  # too short to analyse: the record fails
USER = {"out/plots/mine.png": b"\x89PNG my own plot", "out/notes.txt": "my notes"}
# a staging folder a killed run left on this host (no process has a pid this large)
STALE = f"out/{STAGING}{host_tag()}-99999999-k1lled00"


def _reported(*names: str):
    def check(d: Path) -> None:
        html = (d / "out" / "report.html").read_text(encoding="utf-8")
        doc = json.loads((d / "out" / "results.json").read_text(encoding="utf-8"))
        assert {r["name"] for r in doc["records"]} >= set(names)
        for n in names:
            assert n in html
    return check


def _all_failed(d: Path) -> None:
    doc = json.loads((d / "out" / "results.json").read_text(encoding="utf-8"))
    assert [r["status"] for r in doc["records"]] == ["failed"]
    assert "at least 10" in (d / "out" / "report.html").read_text(encoding="utf-8")
    assert "at least 10" in (d / "out" / "report.md").read_text(encoding="utf-8")


def _all_failed_junit(d: Path) -> None:
    _all_failed(d)
    root = ET.parse(d / "j.xml").getroot()
    assert root.get("tests") == "1" and root.get("errors") == "1"


def _under_reports(folder: str, escape: str | None = None):
    def check(d: Path) -> None:
        assert (d / "reports" / folder / "report.html").is_file()
        if escape is not None:
            assert not (d / escape).exists(), f"{escape} written outside reports/"
    return check


def _nothing_written(d: Path) -> None:
    assert not (d / "o").exists(), "the batch ran before the target was checked"


def _stale_gone(d: Path) -> None:
    assert not (d / STALE).exists()
    assert (d / "out" / "report.html").is_file()


CASES = [
    # a file named plots in the way: one line before the batch, nothing written
    Hostile("out_plots_is_a_file", ("run", "c.yaml", "--out", "out"), 2,
            files={"c.yaml": GOOD, "log.csv": LOG, "out/plots": "mine"}, keep=("out/plots",),
            stderr=("plots", "is a file"), check=lambda d: not (d / "out" / "results.json").exists()
            or (_ for _ in ()).throw(AssertionError("results.json written"))),

    # item 2: only the run's own outputs are replaced
    Hostile("out_keeps_user_plot", ("run", "c.yaml", "--out", "out", "--workers", "1"), 0,
            files={"c.yaml": GOOD, "log.csv": LOG, **USER}, keep=tuple(USER),
            check=_reported("log")),
    Hostile("out_keeps_user_plot_without_plots",
            ("run", "c.yaml", "--out", "out", "--workers", "1"), 0,
            files={"c.yaml": NOPLOTS, "log.csv": LOG, **USER},
            keep=tuple(USER), check=_reported("log")),
    Hostile("identify_out_keeps_user_plot",
            ("identify", "log.csv", "--input", "u", "--output", "y", "--time", "time",
             "--method", "first_order", "--out", "out"), 0,
            files={"log.csv": LOG, **USER}, keep=tuple(USER), check=_reported("log")),
    Hostile("out_dot_keeps_the_folder", ("run", "c.yaml", "--out", ".", "--workers", "1"), 0,
            files={"c.yaml": NOPLOTS, "log.csv": LOG, "plots/mine.png": b"mine",
                   "notes.txt": "x"}, keep=("c.yaml", "log.csv", "plots/mine.png",
                                             "notes.txt")),
    # item 3: name is a label, never a path
    Hostile("name_dotdot_stays_in_reports", ("run", "c.yaml", "--workers", "1"), 0,
            files={"c.yaml": NOPLOTS.replace("name: hostile", "name: ../../escaped-by-name"),
                   "log.csv": LOG},
            check=_under_reports(folder_name("../../escaped-by-name"), "../../escaped-by-name")),
    Hostile("name_absolute_stays_in_reports", ("run", "c.yaml", "--workers", "1"), 0,
            files={"c.yaml": NOPLOTS.replace("name: hostile",
                                          "name: /tmp/pipeline-corpus-absolute-name"),
                   "log.csv": LOG},
            check=_under_reports(folder_name("/tmp/pipeline-corpus-absolute-name"),
                                 "/tmp/pipeline-corpus-absolute-name")),
    Hostile("name_with_slashes_and_spaces", ("run", "c.yaml", "--workers", "1"), 0,
            files={"c.yaml": NOPLOTS.replace("name: hostile", "name: 'Line 2 / oven'"),
                   "log.csv": LOG}, check=_under_reports(folder_name("Line 2 / oven"))),
    # item 9: a killed run's staging folder is removed by the next run
    Hostile("stale_staging_removed", ("run", "c.yaml", "--out", "out", "--workers", "1"), 0,
            files={"c.yaml": NOPLOTS, "log.csv": LOG, f"{STALE}/report.html": "<html>half",
                   "out/notes.txt": "mine"}, keep=("out/notes.txt",), check=_stale_gone),
    # item 11: a bad target is one line, before the batch
    Hostile("out_under_a_file", ("run", "c.yaml", "--out", "afile/sub"), 2,
            files={"c.yaml": GOOD, "log.csv": LOG, "afile": "mine"}, keep=("afile",),
            stderr=("afile is a file, not a folder",)),
    Hostile("out_is_a_file", ("run", "c.yaml", "--out", "afile"), 2,
            files={"c.yaml": GOOD, "log.csv": LOG, "afile": "mine"}, keep=("afile",),
            stderr=("afile", "expected a folder")),
    Hostile("identify_out_under_a_file",
            ("identify", "log.csv", "--input", "u", "--output", "y", "--time", "time",
             "--out", "afile/sub"), 2,
            files={"log.csv": LOG, "afile": "mine"}, keep=("afile",),
            stderr=("afile is a file, not a folder",)),
    Hostile("junit_onto_a_folder", ("run", "c.yaml", "--out", "o", "--junit", "jdir"), 2,
            files={"c.yaml": GOOD, "log.csv": LOG, "jdir/keep.txt": "mine"},
            keep=("jdir/keep.txt",), stderr=("jdir", "JUnit file", "is a folder"),
            check=_nothing_written),
    Hostile("junit_under_a_file", ("run", "c.yaml", "--out", "o", "--junit", "afile/j.xml"),
            2, files={"c.yaml": GOOD, "log.csv": LOG, "afile": "mine"}, keep=("afile",),
            stderr=("JUnit file", "afile is a file"), check=_nothing_written),
    Hostile("history_onto_a_folder", ("run", "c.yaml", "--out", "o", "--history", "hdir"),
            2, files={"c.yaml": GOOD, "log.csv": LOG, "hdir/keep.txt": "mine"},
            keep=("hdir/keep.txt",), stderr=("hdir", "history", "is a folder"),
            check=_nothing_written),
    # item 12: every record failing still writes every output; exit 2
    Hostile("all_records_fail_reported", ("run", "c.yaml", "--out", "out", "--workers", "1"),
            2, files={"c.yaml": BAD, "bad.csv": SHORT}, stderr=("bad.csv",),
            check=_all_failed),
    Hostile("all_records_fail_junit",
            ("run", "c.yaml", "--out", "out", "--workers", "1", "--junit", "j.xml"), 2,
            files={"c.yaml": BAD, "bad.csv": SHORT, "out/notes.txt": "mine"},
            keep=("out/notes.txt",), stderr=("bad.csv",), check=_all_failed_junit),
]
