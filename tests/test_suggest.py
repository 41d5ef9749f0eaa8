"""Typos get the nearest name (issue 29): a method id, a column (a case-only mismatch
such as ``q1`` for ``Q1`` first), a config key; a folder given as a file says so."""

from __future__ import annotations

import pytest
from typer.testing import CliRunner

from pipeline.cli.commands import app
from pipeline.suggest import nearest
from tests.test_cli import _csv

runner = CliRunner()


def test_nearest_prefers_a_case_only_match_and_refuses_far_words():
    assert nearest("q1", ["Q2", "Q1", "q11"]) == "Q1"
    assert nearest("frist_order", ["first_order", "second_order"]) == "first_order"
    assert nearest("zzz", ["first_order", "second_order"]) is None
    assert nearest("u", ["u", "y"]) is None  # the word itself is no suggestion


def _error(args):
    r = runner.invoke(app, args)
    assert r.exit_code == 2, r.output
    (line,) = r.stderr.strip().splitlines()
    assert "Traceback" not in r.output
    return line


def test_cli_method_and_column_typos(tmp_path):
    log = str(_csv(tmp_path))
    base = ["identify", log, "--output", "y", "--time", "time"]
    assert "(did you mean 'first_order'?)" in _error(base + ["--input", "u", "--method",
                                                              "frist_order"])
    assert "no column 'U' (did you mean 'u'?)" in _error(base + ["--input", "U"])


@pytest.mark.parametrize("yaml, says", [
    ("data:\n  path: LOG\n  inptu: u\n  output: y\n", "unknown key 'data.inptu' (did you "
                                                      "mean 'input'?)"),
    ("data:\n  path: LOG\n  input: u\n  output: y\nmethod: all\n",
     "unknown key 'method' (did you mean 'methods'?)"),
    ("data:\n  path: LOG\n  input: u\n  output: y\ntuning:\n  rul: simc\n",
     "unknown key 'tuning.rul' (did you mean 'rule'?)"),
    ("data:\n  path: LOG\n  input: u\n  output: y\nmethods: [first_ordr]\n",
     "unknown method 'first_ordr' (did you mean 'first_order'?)"),
    ("data:\n  path: LOG\n  input: u\n  output: y\n  xyzzy: 1\n",
     "unknown key 'data.xyzzy'; check its spelling (the keys there: dataset, path"),
])
def test_config_key_typos(tmp_path, yaml, says):
    log = _csv(tmp_path)
    cfg = tmp_path / "c.yaml"
    cfg.write_text("name: x\n" + yaml.replace("LOG", str(log)))
    assert says in _error(["run", str(cfg)])


def test_a_folder_given_as_a_file_says_it_is_a_folder(tmp_path):
    line = _error(["identify", str(tmp_path), "--input", "u", "--output", "y"])
    assert line == (f"error: {tmp_path}: is a folder; expected a log file (a folder of logs "
                    "goes in a config's data.path)")
