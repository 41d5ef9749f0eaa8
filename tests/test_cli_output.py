"""The CLI's output in a pipe or a CI log (issue 29): at 80 columns off a terminal every
table line is complete (no identifier, URL, field path or number split across lines),
and ``--json`` gives the same rows to a machine."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from pipeline.cli.catalogue import catalogue
from pipeline.io import load_registry
from tests.test_cli import _csv

ROOT = Path(__file__).resolve().parent.parent


def _pipe(*args: str, cwd: Path | None = None) -> str:
    """``pipeline ARGS | cat`` at 80 columns (what a CI log is): stdout, exit 0."""
    env = {**os.environ, "COLUMNS": "80", "TERM": "dumb"}
    r = subprocess.run([sys.executable, "-m", "pipeline", *args], capture_output=True,
                       text=True, env=env, cwd=cwd, timeout=300)
    assert r.returncode == 0, r.stderr
    return r.stdout


def _row(lines: list[str], first_cell: str) -> str:
    (line,) = [ln for ln in lines if ln.startswith(f"| {first_cell} ")]
    return line


def test_methods_one_complete_line_per_method_and_json():
    lines = _pipe("methods").splitlines()
    methods = catalogue()
    for m in methods:
        row = _row(lines, m["id"])
        assert m["citation"] in row and m["title"] in row
        assert ", ".join(m["structures"]) in row
    assert len(lines) < 2 * len(methods) + 10  # 497 wrapped lines at 80 columns before
    assert json.loads(_pipe("methods", "--json")) == json.loads(json.dumps(methods))


def test_datasets_list_urls_whole_and_json():
    lines = _pipe("datasets", "list").splitlines()
    reg = load_registry()
    for ds in reg.values():
        row = _row(lines, ds.name)
        assert ds.url in row and ds.title in row  # a URL copied from the log works
    doc = json.loads(_pipe("datasets", "list", "--json"))
    assert [d["name"] for d in doc] == list(reg)
    assert [d["url"] for d in doc] == [ds.url for ds in reg.values()]


def test_identify_ranking_rows_keep_methods_flags_and_numbers_whole(tmp_path):
    log = _csv(tmp_path)
    args = [str(log), "--input", "u", "--output", "y", "--time", "time"]
    text = _pipe("identify", *args)
    doc = json.loads(_pipe("identify", *args, "--json"))
    (rec,) = doc["records"]
    lines = text.splitlines()
    shown = 0
    for f in rec["fits"]:
        if f["status"] != "ok":
            continue
        (row,) = [ln for ln in lines if f"| {f['method']} " in ln
                  or f"| {f['method']} *" in ln]
        for flag in f["flags"]:
            assert f" {flag['code']}" in row, (flag["code"], row)
        k = f"K={float(f['params']['K']):.5g}"[:5]  # the gain's leading digits on its row
        assert k in row, (k, row)
        shown += 1
    assert shown >= 10


def test_inspect_field_paths_whole_and_json(tmp_path):
    from mcap.writer import Writer

    path = tmp_path / "log.mcap"
    long_field = "temperature.value_of_the_long_sensor_name"
    with path.open("wb") as fh:
        w = Writer(fh)
        w.start()
        sid = w.register_schema("", "", b"")
        ch = w.register_channel("/plant/heater_1/with_a_long_topic_name", "json",
                                schema_id=sid)
        for i in range(3):
            w.add_message(ch, i, json.dumps(
                {"temperature": {"value_of_the_long_sensor_name": 20.0 + i}}).encode(), i)
        w.finish()
    text = _pipe("inspect", str(path))
    (row,) = [ln for ln in text.splitlines() if "/plant/heater_1/with_a_long_topic_name" in ln]
    assert long_field in row
    doc = json.loads(_pipe("inspect", str(path), "--json"))
    assert doc["topics"][0]["fields"] == [long_field] and doc["message_count"] == 3


@pytest.mark.parametrize("command", [["methods"], ["datasets", "list"]])
def test_on_a_terminal_identifiers_are_never_split(command):
    """A terminal 80 columns wide: rich wraps the long cells, but a method id or a URL
    stays on one line."""
    from rich.console import Console

    from pipeline.cli import commands, output

    console = Console(width=80, force_terminal=True, color_system=None, highlight=False,
                      soft_wrap=True, record=True)
    real = output.out
    output.out = console
    try:
        with console.capture() as cap:
            (commands.methods if command == ["methods"] else commands.datasets_list)()
    finally:
        output.out = real
    text = cap.get()
    words = ([m["id"] for m in catalogue()] if command == ["methods"]
             else [ds.url for ds in load_registry().values()])
    for w in words:
        assert w in text, w


def test_identify_quiet_prints_the_head_and_verbose_the_stages(tmp_path):
    log = _csv(tmp_path)
    args = [str(log), "--input", "u", "--output", "y", "--time", "time"]
    env = {**os.environ, "COLUMNS": "80"}
    run = [sys.executable, "-m", "pipeline", "identify", *args]
    q = subprocess.run([*run, "-q"], capture_output=True, text=True, env=env, timeout=300)
    v = subprocess.run([*run, "-v"], capture_output=True, text=True, env=env, timeout=300)
    doc = json.loads(_pipe("identify", *args, "--json"))
    rec = doc["records"][0]["recommended"]
    assert q.returncode == v.returncode == 0, q.stderr + v.stderr
    lines = q.stdout.splitlines()
    assert lines[0] == f"Recommended model for log: {rec['verdict']}"
    assert f"({rec['method']}, event 0;" in lines[1]
    assert "ranked by" not in q.stdout and q.stderr == ""
    assert "ranked by" in v.stdout
    assert "pipeline: log: loaded 2138 samples" in v.stderr
    assert "fit(s) in" in v.stderr
    both = subprocess.run([*run, "-q", "-v"], capture_output=True, text=True, env=env)
    assert both.returncode == 2 and both.stderr.count("\n") == 1
