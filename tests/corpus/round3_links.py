"""Corpus rows for symbolic links in hardening round 3 (issue 31).

``--junit`` and ``--history`` links: a link to an input is refused as the input would be;
a link to a shared file is written through (the link stays a link, its target gets the
write), a loop of links or a link to a folder is one line. Data folders and patterns: a
link to ``.`` and two link loops are not walked (one log was 41 records; two loops hung the
glob), a link to a file outside the folder is refused by name and its content appears
nowhere, the same file reached twice is one record; a history kept in the data folder is
the run's history, not a log.
"""

from __future__ import annotations

import io
import json
from datetime import UTC, datetime
from pathlib import Path

import polars as pl

from pipeline.gate.history import SCHEMA, load_history
from tests.corpus import Hostile, config, step_csv
from tests.corpus.round3 import EARLIER_JUNIT, INPUTS, LOG, no_report

CFG = config("path: log.csv\ninput: u\noutput: y\ntime: time", extra="report: {plots: none}\n")
FILES = {"c.yaml": CFG, "log.csv": LOG}
RUN = ("run", "c.yaml", "--out", "out", "--workers", "1")


def _history(*records: str) -> bytes:
    """A history of one earlier run (2024-01-01) with a row for each of ``records``."""
    rows = [{"time": datetime(2024, 1, 1, tzinfo=UTC), "record": r, "event": 0,
             "method": "first_order", "status": "ok", "K": 2.0, "T": 5.0} for r in records]
    buf = io.BytesIO()
    pl.DataFrame(rows, schema=SCHEMA).write_parquet(buf)
    return buf.getvalue()


HISTORY = _history("log")


def _still_links(*names: str):
    def check(d: Path) -> None:
        for name in names:
            assert (d / name).is_symlink(), f"{name} is no longer a link"
    return check


def _refused_link(kind: str, option: tuple[str, ...], links: dict[str, str], needle: str,
                  *, extra=None, keep: tuple[str, ...] = INPUTS) -> Hostile:
    def check(d: Path) -> None:
        no_report(d)
        _still_links(*links)(d)
    return Hostile(kind, (*RUN, *option), 2, files={**FILES, **(extra or {})}, links=links,
                   stderr=(needle,), keep=keep, max_lines=1, check=check)


def _written_through(junit: str | None, history: str | None, runs: int = 1):
    """A check: the links are still links; the JUnit target is a JUnit file, the history
    target holds ``runs`` runs."""
    def check(d: Path) -> None:
        if junit is not None:
            assert (d / "j.xml").is_symlink()
            text = (d / junit).read_text(encoding="utf-8")
            assert text.count("<testsuites") == 1 and 'earlier="yes"' not in text
        if history is not None:
            assert (d / "h.parquet").is_symlink()
            assert load_history(d / history)["time"].n_unique() == runs
    return check


CASES = [
    _refused_link("junit_link_to_the_config", ("--junit", "j.xml"), {"j.xml": "c.yaml"},
                  "j.xml: the JUnit file would replace the config (c.yaml)"),
    _refused_link("junit_link_to_the_log", ("--junit", "j.xml"), {"j.xml": "log.csv"},
                  "j.xml: the JUnit file would replace the log of record 'log'"),
    _refused_link("history_link_to_the_config", ("--history", "h.parquet"),
                  {"h.parquet": "c.yaml"},
                  "h.parquet: the history would replace the config (c.yaml)"),
    _refused_link("history_link_to_the_junit_file",
                  ("--junit", "j.xml", "--history", "h.parquet"), {"h.parquet": "j.xml"},
                  "h.parquet: the history would replace the JUnit file (j.xml)"),
    _refused_link("junit_link_to_a_foreign_file", ("--junit", "j.xml"),
                  {"j.xml": "notes.xml"},
                  "j.xml: exists and is not a JUnit file pipeline wrote",
                  extra={"notes.xml": "<notes>mine</notes>\n"}, keep=(*INPUTS, "notes.xml")),
    _refused_link("junit_link_to_a_folder", ("--junit", "j.xml"), {"j.xml": "jdir"},
                  "which is not a regular file", extra={"jdir/keep.txt": "mine"},
                  keep=(*INPUTS, "jdir/keep.txt")),
    _refused_link("junit_link_loop", ("--junit", "a.xml"),
                  {"a.xml": "b.xml", "b.xml": "a.xml"},
                  "a.xml: cannot write the JUnit file (a loop of symbolic links)"),
    _refused_link("history_link_loop", ("--history", "a.parquet"),
                  {"a.parquet": "b.parquet", "b.parquet": "a.parquet"},
                  "a.parquet: cannot write the history (a loop of symbolic links)"),
    # the twins: links to shared files are written through, and stay links
    Hostile("junit_and_history_dangling_links_written_through",
            (*RUN, "--junit", "j.xml", "--history", "h.parquet"), 0, files=FILES,
            links={"j.xml": "shared/j.xml", "h.parquet": "shared/h.parquet"}, keep=INPUTS,
            max_lines=0, check=_written_through("shared/j.xml", "shared/h.parquet")),
    Hostile("junit_link_to_an_earlier_junit_file_written_through",
            (*RUN, "--junit", "j.xml"), 0, files={**FILES, "shared/j.xml": EARLIER_JUNIT},
            links={"j.xml": "shared/j.xml"}, keep=INPUTS, max_lines=0,
            check=_written_through("shared/j.xml", None)),
    Hostile("history_link_to_a_shared_history_appended",
            (*RUN, "--history", "h.parquet"), 0, files={**FILES, "shared/h.parquet": HISTORY},
            links={"h.parquet": "shared/h.parquet"},
            keep=INPUTS, max_lines=0, check=_written_through(None, "shared/h.parquet", 2)),
    Hostile("history_absolute_link_appended", (*RUN, "--history", "h.parquet"), 0,
            files={**FILES, "shared/h.parquet": HISTORY},
            links={"h.parquet": "{d}/shared/h.parquet"}, keep=INPUTS, max_lines=0,
            check=_written_through(None, "shared/h.parquet", 2)),
]

# -- links in data folders and patterns ---------------------------------------------------

SECRET = "hunter2-corpus-secret"
DATA = {"data/a.csv": LOG, "data/day1/b.csv": step_csv(n=200, seed=1),
        "credentials.csv": f"user,password\nroot,{SECRET}\n",
        "outside/more.csv": f"time,u,y\n0,0,{SECRET}\n"}


def _data_cfg(path: str) -> str:
    return config(f"path: '{path}'\ninput: u\noutput: y\ntime: time",
                  extra="report: {plots: none}\n")


def _records(*expected: str):
    """A check: the run's records are of ``expected`` (paths in the case folder)."""
    def check(d: Path) -> None:
        doc = json.loads((d / "out" / "results.json").read_text(encoding="utf-8"))
        got = sorted(_inside(Path(r["source"]), d) for r in doc["records"])
        assert got == sorted(expected), got
        assert all(r["status"] == "ok" for r in doc["records"])
    return check


def _inside(source: Path, d: Path) -> str:
    """``source`` relative to the case folder (the link's name, not its target's)."""
    for root in (d, d.resolve()):
        if source.is_relative_to(root):
            return source.relative_to(root).as_posix()
    return source.as_posix()


def _secret_nowhere(d: Path) -> None:
    """The planted secret is in no file but the ones it was planted in."""
    planted = {d / "credentials.csv", d / "outside" / "more.csv"}
    for p in d.rglob("*"):
        if p.is_file() and not p.is_symlink() and p not in planted:
            assert SECRET.encode() not in p.read_bytes(), f"{p} holds the secret"
    no_report(d)


def _data(kind: str, path: str, code: int, links: dict[str, str], *, stderr=(), check=None,
          extra=None) -> Hostile:
    return Hostile(kind, RUN, code, files={"c.yaml": _data_cfg(path), **DATA, **(extra or {})},
                   links=links, keep=("data/a.csv", "credentials.csv"), stderr=stderr,
                   absent=(SECRET,), max_lines=1 if code else 0, check=check)


OUTSIDE = ("a link to a file outside", "data folders and patterns name the files inside them")

CASES += [
    _data("data_link_to_dot_not_walked", "data/**/*.csv", 0,
          {"data/again": ".", "data/day1/up": ".."},
          check=_records("data/a.csv", "data/day1/b.csv")),
    _data("data_folder_with_a_link_to_dot", "data", 0, {"data/again": "."},
          check=_records("data/a.csv")),
    _data("data_glob_through_two_link_loops", "data/**/*.csv", 0,
          {"data/loop1": "../data", "data/day1/loop2": "../../data/day1"},
          check=_records("data/a.csv", "data/day1/b.csv")),
    *(_data(f"data_link_outside_refused_{form}", path, 2,
            {"data/z.csv": "../credentials.csv"}, stderr=("data/z.csv", *OUTSIDE),
            check=_secret_nowhere)
      for form, path in (("folder", "data"), ("glob", "data/*.csv"),
                         ("globstar", "data/**/*.csv"))),
    _data("data_absolute_link_outside_refused", "data/*.csv", 2,
          {"data/z.csv": "{d}/credentials.csv"}, stderr=("data/z.csv", *OUTSIDE),
          check=_secret_nowhere),
    _data("data_link_to_a_folder_outside_refused", "data/*/*.csv", 2,
          {"data/ext": "../outside"}, stderr=("data/ext/more.csv", *OUTSIDE),
          check=_secret_nowhere),
    _data("data_globstar_does_not_walk_a_link_outside", "data/**/*.csv", 0,
          {"data/ext": "../outside", "data/up": ".."},
          check=_records("data/a.csv", "data/day1/b.csv")),
    # the twins: a link named itself is read; the same file reached twice is one record
    _data("data_link_named_itself_is_read", "data/z.csv", 0, {"data/z.csv": "../other.csv"},
          extra={"other.csv": LOG}, check=_records("data/z.csv")),
    _data("data_link_inside_is_one_record", "data/**/*.csv", 0,
          {"data/b_link.csv": "day1/b.csv"}, check=_records("data/a.csv", "data/b_link.csv")),
]

# -- a history kept in the data folder ----------------------------------------------------

NOT_A_LOG = "logs/history.parquet: the run's history, not read as a log"


def _history_grew(runs: int):
    def check(d: Path) -> None:
        doc = json.loads((d / "out" / "results.json").read_text(encoding="utf-8"))
        assert [r["name"] for r in doc["records"]] == ["log"]
        assert load_history(d / "logs" / "history.parquet")["time"].n_unique() == runs
    return check


def _in_logs(kind: str, path: str, code: int, *, history: bytes | None, stderr=(),
             check=None, log: bool = True) -> Hostile:
    files = {"c.yaml": _data_cfg(path), **({"logs/log.csv": LOG} if log else {}),
             **({"logs/history.parquet": history} if history is not None else {})}
    keep = ("c.yaml", "logs/history.parquet") if code else ("c.yaml",)
    return Hostile(kind, (*RUN, "--history", "logs/history.parquet"), code, files=files,
                   keep=keep, stderr=stderr, max_lines=1, check=check)


CASES += [
    _in_logs("history_in_the_data_folder_not_read", "logs", 0, history=HISTORY,
             stderr=(NOT_A_LOG,), check=_history_grew(2)),
    _in_logs("history_in_the_data_folder_glob_not_read", "logs/*", 0, history=HISTORY,
             stderr=(NOT_A_LOG,), check=_history_grew(2)),
    # the twin: the first night, with no history yet, creates it
    _in_logs("history_in_the_data_folder_first_night", "logs", 0, history=None,
             check=_history_grew(1)),
    _in_logs("history_alone_in_the_data_folder_refused", "logs", 2, history=HISTORY,
             log=False, stderr=("the history would replace the log of record 'history'",),
             check=no_report),
]
