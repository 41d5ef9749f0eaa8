"""A config's data folder or pattern names the files inside it (issue 31): links to ``.``
and link loops are not walked (one log was 41 records; two loops hung the glob), a link
to a file outside the folder is refused by name (its content reached the report), the
same file reached twice is one record; plain folders and patterns are unchanged."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from pipeline.errors import UserError
from pipeline.io.paths import files_named

LOG = "t,u,y\n0,1,2\n1,2,3\n"


@pytest.fixture
def data(tmp_path: Path) -> Path:
    d = tmp_path / "data"
    (d / "day1").mkdir(parents=True)
    (d / "a.csv").write_text(LOG)
    (d / "day1" / "b.csv").write_text(LOG)
    (d / "day1" / "notes.txt").write_text("not a log")
    (d / ".hidden").mkdir()
    (d / ".hidden" / "c.csv").write_text(LOG)
    return d


def names(files, root: Path) -> list[str]:
    return [f.relative_to(root).as_posix() for f in files]


def test_plain_folders_and_patterns_name_what_they_did(data: Path):
    base = data.parent
    assert names(files_named("data", base), data) == ["a.csv"]
    assert names(files_named("data/*.csv", base), data) == ["a.csv"]
    assert names(files_named("data/**/*.csv", base), data) == ["a.csv", "day1/b.csv"]
    assert names(files_named("data/day?/*.csv", base), data) == ["day1/b.csv"]
    assert names(files_named("data/**/[ab].csv", base), data) == ["a.csv", "day1/b.csv"]
    assert names(files_named("data/**/[!a].csv", base), data) == ["day1/b.csv"]
    assert names(files_named(str(data / "**" / "*.csv"), base), data) == ["a.csv",
                                                                           "day1/b.csv"]


def test_a_link_to_the_folder_itself_is_not_walked(data: Path):
    os.symlink(".", data / "again")
    os.symlink("..", data / "day1" / "up")
    base = data.parent
    assert names(files_named("data/**/*.csv", base), data) == ["a.csv", "day1/b.csv"]
    assert names(files_named("data", base), data) == ["a.csv"]


def test_two_link_loops_end(data: Path):
    os.symlink("../data", data / "loop1")
    os.symlink("../../data/day1", data / "day1" / "loop2")
    assert names(files_named("data/**/*.csv", data.parent), data) == ["a.csv", "day1/b.csv"]


def test_a_link_to_a_file_outside_is_refused_by_name(data: Path):
    secret = data.parent / "credentials.csv"
    secret.write_text("user,password\nroot,hunter2\n")
    os.symlink(secret, data / "z.csv")
    for pattern in ("data", "data/*.csv", "data/**/*.csv"):
        with pytest.raises(UserError) as err:
            files_named(pattern, data.parent)
        message = str(err.value)
        assert "z.csv" in message and "outside" in message and "hunter2" not in message


def test_the_same_file_twice_is_one_record_and_a_link_inside_is_kept(data: Path):
    os.symlink("day1/b.csv", data / "b_link.csv")
    got = names(files_named("data/**/*.csv", data.parent), data)
    assert got == ["a.csv", "b_link.csv"]  # b.csv is the file b_link.csv already names
    assert names(files_named("data", data.parent), data) == ["a.csv", "b_link.csv"]


def test_a_history_kept_in_the_data_folder_is_not_read_as_a_log(tmp_path: Path):
    """Issue 31: ``--history logs/history.parquet`` beside the logs; the second night
    reads the two logs, not the history, says so on stderr, and appends its rows."""
    import polars as pl
    from typer.testing import CliRunner

    from pipeline.cli.commands import app
    from pipeline.synth.logs import write_synthetic_logs

    logs = tmp_path / "logs"
    write_synthetic_logs(logs, 2, seed=1)
    config = tmp_path / "c.yaml"
    config.write_text(f"name: n\ndata:\n  path: {logs}\n  input: u\n  output: y\n"
                      "  time: time\nmethods: [first_order]\nreport: {plots: none}\n")
    history = logs / "history.parquet"
    runner = CliRunner()
    for night in (1, 2):
        r = runner.invoke(app, ["run", str(config), "--out", str(tmp_path / f"o{night}"),
                                "--workers", "1", "--history", str(history)])
        assert r.exit_code == 0, r.output
        assert ("not read as a log" in r.stderr) == (night == 2)
        assert "2 of 2 record(s)" in r.stdout
    assert pl.read_parquet(history).height == 4
