"""User text reaches messages, plots, report.md, the terminal and JUnit as text (issue 13,
items 4-7 and 20): quoted short, drawn literally, escaped for Markdown, control characters
made visible, and the JUnit file valid against the Jenkins xUnit schema's rules."""

from __future__ import annotations

import re
import xml.etree.ElementTree as ET

import pytest
from markdown_it import MarkdownIt
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from typer.testing import CliRunner

from pipeline.cli.commands import app
from pipeline.config import config_from_dict, load_config
from pipeline.errors import UserError
from pipeline.quoting import printable, quoted
from pipeline.report.build import render
from pipeline.report.drawing import literal_text
from pipeline.report.junit import junit_xml
from pipeline.report.markdown import md_code, md_text
from pipeline.results import RecordResult, RunResult
from tests.corpus import step_csv

# -- item 4: messages quote short --------------------------------------------------------


def alias_bomb(key: str, levels: int = 9) -> str:
    """``key: [...]`` whose anchors nest ``levels`` deep, nine aliases each: 9**levels
    strings behind a few hundred bytes (9 levels: 387 M strings, the issue's 467 bytes)."""
    names = "abcdefghijklmnop"
    parts = ['&a ["lol","lol","lol","lol","lol","lol","lol","lol","lol"]']
    parts += [f"&{names[k]} [" + ",".join([f"*{names[k - 1]}"] * 9) + "]"
              for k in range(1, levels)]
    return f"{key}: [" + ", ".join(parts) + "]\n"


DATA = "data:\n  path: log.csv\n  input: u\n  output: y\n"


@pytest.mark.parametrize("where", ["name", "initial_input"])
def test_alias_bomb_is_refused_in_one_short_line(tmp_path, where):
    text = (alias_bomb("name") + DATA if where == "name"
            else "name: x\n" + DATA + "  " + alias_bomb("initial_input"))
    assert len(text.encode()) < 500
    path = tmp_path / "c.yaml"
    path.write_text(text)
    with pytest.raises(UserError) as exc:
        load_config(path)
    message = exc.value.message
    assert "c.yaml" in message and "aliases" in message and "100,000" in message
    assert len(message) < 300


def test_a_huge_value_is_quoted_short():
    # past the YAML guard (a dict from Python): the error quotes 9**6 shared strings;
    # the whole repr was 4.3 MB of message before
    value = ["lol"] * 9
    for _ in range(5):
        value = [value] * 9
    with pytest.raises(UserError) as exc:
        config_from_dict({"name": value, "data": {"path": "log.csv", "input": "u",
                                                  "output": "y"}})
    message = exc.value.message
    assert "key 'name'" in message and "(got [[[" in message
    assert len(message) < 200
    with pytest.raises(UserError) as exc:
        config_from_dict({"data": {"path": "log.csv", "input": "u", "output": "y",
                                   "initial_input": "x" * 1_000_000}})
    assert "key 'data.initial_input'" in exc.value.message
    assert len(exc.value.message) < 300


def test_quoted_and_printable():
    assert quoted("abc") == "'abc'"
    long = quoted("x" * 10_000 + "END")
    assert len(long) <= 80 and long.endswith("END'") and "..." in long
    assert quoted(list(range(10**6))).startswith("[0, 1, 2, 3, ...")
    assert printable("a\x1b[31mb\x07c\nd") == "a\\x1b[31mb\\x07c\\x0ad"
    assert printable("a\tb\nc\x00", lines=True) == "a\tb\nc\\x00"
    assert printable("caf\u00e9 \u00b5s \udcff \u202e") == "caf\u00e9 \u00b5s \\udcff \\u202e"


def test_a_self_referring_config_is_refused(tmp_path):
    path = tmp_path / "c.yaml"
    path.write_text("name: &a [*a]\n" + DATA)
    with pytest.raises(UserError, match="refer to themselves"):
        load_config(path)
    path.write_text("name: " + "[" * 5000 + "]" * 5000 + "\n")
    with pytest.raises(UserError, match="nested too deeply"):
        load_config(path)


# -- items 5, 6, 7: hostile names through a whole run ---------------------------------------

HOSTILE = "run $x$ <script>alert(1)<\u2215script> | a`b \\frac_^ \x1b[31m\x07"
INPUT = "u $\\frac$ _^"
OUTPUT = "y|<img src=x onerror=alert(1)>"


def _cells(line: str) -> int:
    """Cells of a GFM table row: ``|`` not escaped by a backslash separates them."""
    count, k = 0, 0
    while k < len(line):
        if line[k] == "\\":
            k += 2
            continue
        count += line[k] == "|"
        k += 1
    return count - 1


def tables(md: str) -> list[list[str]]:
    """The Markdown tables of a document, as lists of their lines."""
    out, cur = [], []
    for line in md.splitlines():
        if line.startswith("|"):
            cur.append(line)
        elif cur:
            out.append(cur)
            cur = []
    return out + ([cur] if cur else [])


def assert_safe_markdown(md: str, n_tables: int) -> None:
    found = tables(md)
    assert len(found) >= n_tables
    for table in found:
        width = _cells(table[0])
        assert re.fullmatch(r"\|(---\|)+", table[1])
        assert [_cells(row) for row in table] == [width] * len(table), table
    assert "<script" not in md and "<img" not in md and "\x1b" not in md
    page = MarkdownIt("commonmark", {"html": True}).enable("table").render(md)
    assert "<script" not in page and "<img src=x" not in page
    assert page.count("<table>") == len(found)


@pytest.fixture(scope="module")
def hostile_run(tmp_path_factory):
    d = tmp_path_factory.mktemp("hostile")
    (d / f"{HOSTILE}.csv").write_text(step_csv(header=f"time,{INPUT},{OUTPUT}"))
    (d / "c.yaml").write_text(
        "name: n\ndata:\n  path: '*.csv'\n"
        f"  input: '{INPUT}'\n  output: '{OUTPUT}'\n  time: time\n"
        "  units: {time: s, input: '$x$_^', output: '<b>|$'}\n"
        "methods: [first_order, lsq_first_order]\n"
        "report: {title: 'T $\\frac{a}{$ <script>x</script>', plots: full}\n")
    result = CliRunner().invoke(app, ["run", str(d / "c.yaml"), "--out", str(d / "out"),
                                      "--junit", str(d / "junit.xml"), "--workers", "1"])
    return d, result


def test_dollar_and_tex_in_names_units_title_draw(hostile_run):
    d, result = hostile_run
    assert result.exit_code == 0, result.output
    pngs = sorted((d / "out" / "plots").glob("*.png"))
    # compare, overview, ranking, identification and validation overlays, the tuned loop
    assert len(pngs) == 6
    assert all(p.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" for p in pngs)
    assert "Glyph" not in result.stderr and "Traceback" not in result.output


def test_report_md_escapes_names_units_title(hostile_run):
    d, _ = hostile_run
    md = (d / "out" / "report.md").read_text()
    assert_safe_markdown(md, n_tables=4)
    assert "&lt;script&gt;alert(1)" in md and "y\\|&lt;img src=x onerror" in md
    html = (d / "out" / "report.html").read_text()
    assert "<script" not in html and "<img src=x" not in html and "\x1b" not in html


def test_junit_is_well_formed_with_control_characters(hostile_run):
    d, _ = hostile_run
    text = (d / "junit.xml").read_text()
    assert "\x1b" not in text and "\x07" not in text
    root = ET.fromstring(text)
    classnames = {c.get("classname") for c in root.iter("testcase")}
    assert any("\\x1b[31m\\x07" in c for c in classnames), classnames
    assert_junit_10(root)


def test_a_failed_record_with_a_pipe_in_its_reason_keeps_the_table():
    bad = RecordResult(name="bad | <img src=x onerror=alert(1)>", source="bad.csv",
                       error="bad.csv: column 'a|b' <script>x</script> not found\nsecond")
    run = RunResult([bad], config="c | `x` <b>")
    md, html, _ = render(run, run.to_doc(), title="t | <script>", plots_mode="none")
    assert_safe_markdown(md, n_tables=1)
    assert "<script" not in html


def test_md_code_spans_hold_backticks():
    page = MarkdownIt("commonmark").render(f"x {md_code('a ``b` c', table=False)} y")
    assert "<code>a ``b` c</code>" in page
    assert str(md_text("[a](javascript:x)")) == "[a]\\(javascript:x)"
    assert "href" not in MarkdownIt("commonmark").render(str(md_text("[a](http://x)")))


def test_terminal_escapes_reach_stderr_inert(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    name = "log\x1b[31m\x07\x1b]0;owned\x07.csv"
    (tmp_path / name).write_text("time,u,y\n")  # header only: one error line
    result = CliRunner().invoke(app, ["identify", name, "--input", "u", "--output", "y",
                                      "--time", "time"])
    assert result.exit_code == 2
    assert "\x1b" not in result.stderr and "\x07" not in result.stderr
    assert "log\\x1b[31m\\x07\\x1b]0;owned\\x07.csv" in result.stderr


def test_mcap_topic_with_escapes_is_shown_inert(tmp_path):
    from mcap.writer import Writer

    path = tmp_path / "log.mcap"
    with path.open("wb") as fh:
        w = Writer(fh)
        w.start()
        sid = w.register_schema("", "", b"")
        ch = w.register_channel("/u\x1b[2J\x07", "json", schema_id=sid)
        w.add_message(ch, 1, b'{"data": 1.0}', 1)
        markup = w.register_channel("/a[/b]", "json", schema_id=sid)  # rich markup
        w.add_message(markup, 1, b'{"data": 1.0}', 1)
        w.finish()
    result = CliRunner().invoke(app, ["identify", str(path), "--input", "/nope:data",
                                      "--output", "/u:data"])
    assert result.exit_code == 2, result.output
    assert "\x1b" not in result.stderr and "\x07" not in result.stderr
    assert "/u\\x1b[2J\\x07" in result.stderr
    listing = CliRunner().invoke(app, ["inspect", str(path)])
    assert listing.exit_code == 0, listing.output  # a MarkupError before
    assert "\x1b" not in listing.stdout and "/u\\x1b[2J" in listing.stdout
    assert "/a[/b]" in listing.stdout


def test_literal_text_keeps_log_tick_mathtext():
    fig = Figure()
    FigureCanvasAgg(fig)
    ax = fig.add_subplot()
    ax.plot([1, 10, 100], [1, 2, 3], label="$\\frac$")
    ax.set_xscale("log")
    ax.set_title("$\\frac_^$")
    ax.annotate("a$b$c", (1, 1))
    ax.legend()
    literal_text(fig)
    fig.canvas.draw()  # raised ValueError (mathtext) before
    assert not ax.title.get_parse_math() and not ax.get_legend().get_texts()[0].get_parse_math()
    ticks = [t for t in ax.get_xticklabels() if t.get_text()]
    assert ticks and all(t.get_parse_math() for t in ticks)
    assert any("10^" in t.get_text() for t in ticks)


# -- item 20: the JUnit file against the Jenkins xUnit schema -----------------------------

#: The rules of the Jenkins xUnit plugin's JUnit schema, junit-10.xsd (jenkinsci/xunit-plugin,
#: src/main/resources/org/jenkinsci/plugins/xunit/types/model/xsd/junit-10.xsd, commit
#: 031e285e; MIT, (c) 2014 Gregory Boissinot): per element, its attributes (required ones
#: first, then "|", then the optional ones) and the child elements it may hold. Neither
#: lxml nor xmlschema is installed in the dev environment, so the test checks these rules
#: with ElementTree instead of validating against the XSD itself.
JUNIT_10 = {
    "testsuites": ("| name time tests failures errors", {"testsuite"}),
    "testsuite": ("name tests failures errors | group time skipped timestamp hostname id "
                  "package file log url",
                  {"testsuite", "properties", "testcase", "system-out", "system-err"}),
    "properties": ("|", {"property"}),
    "property": ("name value |", set()),
    "testcase": ("name | time classname group",
                 {"skipped", "error", "failure", "rerunFailure", "rerunError",
                  "flakyFailure", "flakyError", "system-out", "system-err"}),
    "skipped": ("| type message", set()),
    "error": ("| type message", set()),
    "failure": ("| type message", set()),
}
SUREFIRE_TIME = re.compile(r"(([0-9]{0,3},)*[0-9]{3}|[0-9]{0,3})*(\.[0-9]*)?")


def assert_junit_10(root: ET.Element) -> None:
    assert root.tag == "testsuites"
    for el in root.iter():
        assert el.tag in JUNIT_10, el.tag
        spec, children = JUNIT_10[el.tag]
        required, _, optional = spec.partition("|")
        assert set(required.split()) <= set(el.attrib), (el.tag, el.attrib)
        assert set(el.attrib) <= set(required.split()) | set(optional.split()), (
            el.tag, set(el.attrib))
        assert {c.tag for c in el} <= children, (el.tag, [c.tag for c in el])
        if el.tag in ("testsuites", "testsuite") and "time" in el.attrib:
            assert SUREFIRE_TIME.fullmatch(el.get("time")), el.get("time")


def test_junit_follows_the_xunit_schema():
    ok = RecordResult(name="ok", source="ok.csv")
    bad = RecordResult(name="bad\x01\x1b[0m", source="bad.csv", error="bad.csv: empty")
    doc = RunResult([ok, bad], config="c.yaml", created="2024-01-01T00:00:00+00:00").to_doc()
    root = ET.fromstring(junit_xml(doc, time=12.5, hostname="ci-7"))
    assert_junit_10(root)
    suite = root.find("testsuite")
    assert "skipped" not in root.attrib and suite.get("skipped") == "0"
    assert root.get("time") == suite.get("time") == "12.500000"  # microseconds: a fit < 1 ms
    assert suite.get("hostname") == "ci-7" and suite.get("timestamp").startswith("2024")
    assert root.get("errors") == "1"
    (case,) = [c for c in root.iter("testcase") if c.find("error") is not None]
    assert case.get("classname") == "bad\\x01\\x1b[0m"
    assert junit_xml(doc).count('hostname="') == 1  # this machine's name by default


def test_assert_junit_10_catches_what_the_schema_rejects():
    bad = ET.fromstring('<testsuites skipped="0"><testsuite name="a" tests="0" failures="0" '
                        'errors="0"/></testsuites>')
    with pytest.raises(AssertionError):
        assert_junit_10(bad)


def test_a_user_error_is_one_bounded_line():
    message = UserError("f.csv: column " + "x" * 1_000_000 + "\nnot found; expected u").message
    assert len(message) <= UserError.MAX_LENGTH and "\n" not in message
    assert message.startswith("f.csv: column xxx") and message.endswith("expected u")


def test_consistency_figures_draw_units_with_dollars_and_tex():
    from pipeline.grading.consistency import EventEstimate, StaticMap
    from pipeline.report.consistency_plots import consistency_figure, static_map_figure

    units = {"time": "s", "input": "$\\frac$", "output": "_^$x$"}
    est = [EventEstimate(index=k, t0=10.0 * k, u0=float(k), u1=float(k + 1), y0=2.0 * k,
                         y_inf=2.0 * k + 2, K=2.0 + 0.1 * k, K_ci=(1.9, 2.3), T=5.0,
                         T_ci=(4.5, 5.5)) for k in range(3)]
    smap = StaticMap(u=(0.0, 1.0, 2.0), y=(0.0, 2.0, 4.1), line=(0.0, 2.0),
                     quadratic=(0.0, 2.0, 0.01), rms_line=0.05, rms_quadratic=0.01,
                     nonlinear=True, p_curvature=0.01)
    # tight_layout drew the labels as mathtext before: ValueError
    assert consistency_figure(est, units, dpi=40)[:4] == b"\x89PNG"
    assert static_map_figure(smap, units, dpi=40)[:4] == b"\x89PNG"


def test_a_user_error_names_control_characters_as_escapes():
    """A \\x0b or \\r in a file name is written as an escape, not folded into a space
    (the line must name the file that exists); line breaks and tabs fold to one line."""
    from pipeline.errors import UserError

    msg = UserError("cannot read\n/data/ctl\x01\x0b\r.csv:\tbad").message
    assert msg == "cannot read /data/ctl\\x01\\x0b\\x0d.csv: bad"
