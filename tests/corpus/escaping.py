"""Corpus rows for user text that reaches messages, plots, reports and JUnit (issue 13
items 4-7): alias bombs, ``$`` and TeX in names, units and titles, HTML and pipes in
names and reasons, control characters and terminal escapes in file names."""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

from tests.corpus import Hostile, config, step_csv
from tests.test_escaping import alias_bomb, assert_junit_10, assert_safe_markdown

GOOD = step_csv()
IDENTIFY = ("--input", "u", "--output", "y", "--time", "time", "--method", "first_order")
DATA = "data:\n  path: log.csv\n  input: u\n  output: y\n  time: time\n"


def plotted(out: str = "out", at_least: int = 3):
    """A check: the report in ``out`` was written with its plots."""
    def check(d: Path) -> None:
        pngs = list((d / out / "plots").glob("*.png"))
        assert len(pngs) >= at_least, pngs
        assert (d / out / "report.md").is_file() and (d / out / "report.html").is_file()
    return check


def safe_report(out: str = "out", n_tables: int = 1, junit: str | None = None):
    """A check: report.md's tables keep their columns and hold no raw HTML; the JUnit file
    (when given) parses and follows the xUnit schema's rules."""
    def check(d: Path) -> None:
        assert_safe_markdown((d / out / "report.md").read_text(), n_tables)
        assert "<script" not in (d / out / "report.html").read_text()
        if junit is not None:
            assert_junit_10(ET.parse(d / junit).getroot())
    return check


CASES = [
    # --verbose names each record's file: its escape sequences are inert there too
    Hostile("verbose_lines_escape_file_names", ("run", "c.yaml", "--out", "out", "-v",
                                                "--workers", "1"), 0,
            files={"c.yaml": "name: v\ndata:\n  path: '*.csv'\n  input: u\n  output: y\n"
                             "  time: time\nmethods: [first_order]\nreport: {plots: none}\n",
                   "\x1b]0;pwn\x07\x1b[31mred.csv": GOOD}, max_lines=30),

    Hostile("yaml_alias_bomb_in_name", ("run", "c.yaml"), 2,
            files={"c.yaml": alias_bomb("name") + DATA, "log.csv": GOOD},
            stderr=("c.yaml", "aliases"), keep=("c.yaml",)),
    Hostile("yaml_alias_bomb_in_initial_input", ("run", "c.yaml"), 2,
            files={"c.yaml": "name: x\n" + DATA + "  " + alias_bomb("initial_input"),
                   "log.csv": GOOD},
            stderr=("c.yaml", "aliases")),
    Hostile("yaml_alias_refers_to_itself", ("run", "c.yaml"), 2,
            files={"c.yaml": "name: &a [*a]\n" + DATA, "log.csv": GOOD},
            stderr=("c.yaml", "refer to themselves")),
    Hostile("yaml_nested_too_deeply", ("run", "c.yaml"), 2,
            files={"c.yaml": "name: " + "[" * 3000 + "]" * 3000 + "\n"},
            stderr=("c.yaml", "nested too deeply")),
    Hostile("yaml_long_value_quoted_short", ("run", "c.yaml"), 2,
            files={"c.yaml": "name: x\n" + DATA + "  initial_input: " + "x" * 100_000 + "\n",
                   "log.csv": GOOD},
            stderr=("data.initial_input", "xxx...xxx")),
    Hostile("dollar_tex_in_file_name", ("identify", "a $\\frac_^$ b.csv", *IDENTIFY,
                                        "--out", "out"), 0,
            files={"a $\\frac_^$ b.csv": GOOD}, max_lines=0, check=plotted()),
    Hostile("dollar_tex_in_column_names",
            ("identify", "log.csv", "--input", "u $\\frac$", "--output", "y_^$x", "--time",
             "time", "--method", "first_order", "--out", "out"), 0,
            files={"log.csv": step_csv(header="time,u $\\frac$,y_^$x")}, max_lines=0,
            check=plotted()),
    Hostile("dollar_tex_in_units_and_title", ("run", "c.yaml", "--out", "out"), 0,
            files={"c.yaml": config("path: log.csv\ninput: u\noutput: y\ntime: time\n"
                                    "units: {time: s, input: '$\\frac$', output: '$x$_^'}",
                                    extra="report: {title: 'T $\\frac{a}{ $', plots: full}\n"),
                   "log.csv": GOOD}, max_lines=0, check=plotted()),
    Hostile("script_in_file_name", ("identify", "<script>alert(1)<script>.csv", *IDENTIFY,
                                    "--out", "out"), 0,
            files={"<script>alert(1)<script>.csv": GOOD}, max_lines=0,
            check=safe_report(n_tables=4)),
    Hostile("img_onerror_in_column_name",
            ("identify", "log.csv", "--input", "u", "--output", "<img src=x onerror=alert(1)>",
             "--time", "time", "--method", "first_order", "--out", "out"), 0,
            files={"log.csv": step_csv(header="time,u,<img src=x onerror=alert(1)>")},
            max_lines=0, check=safe_report(n_tables=4)),
    Hostile("pipe_and_html_in_a_failed_reason",
            ("run", "c.yaml", "--out", "out", "--junit", "junit.xml", "--workers", "1"), 3,
            files={"c.yaml": config("paths: [good.csv, 'bad | <b>x</b>.csv']\ninput: u\n"
                                    "output: y\ntime: time"),
                   "good.csv": GOOD, "bad | <b>x</b>.csv": "time,u,y\n"},
            stderr=("bad | <b>x</b>.csv",),
            check=safe_report(n_tables=2, junit="junit.xml")),
    Hostile("control_characters_in_name_junit",
            ("run", "c.yaml", "--out", "out", "--junit", "junit.xml", "--workers", "1"), 0,
            files={"c.yaml": config('path: "ctl\\x01\\x02\\x0b.csv"\ninput: u\noutput: y\n'
                                    "time: time"),
                   "ctl\x01\x02\x0b.csv": GOOD}, max_lines=0,
            check=safe_report(n_tables=4, junit="junit.xml")),
    Hostile("terminal_escape_in_file_name",
            ("identify", "log\x1b[31m\x1b]0;owned\x07.csv", *IDENTIFY), 2,
            files={"log\x1b[31m\x1b]0;owned\x07.csv": "time,u,y\n"},
            stderr=("log\\x1b[31m\\x1b]0;owned\\x07.csv",)),
    Hostile("bell_and_escape_in_missing_file", ("identify", "nope\x07\x1b[2J.csv", *IDENTIFY),
            2, stderr=("nope\\x07\\x1b[2J.csv",)),
]
