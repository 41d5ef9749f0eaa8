"""The regression gate per record (issue 13 item 18) and which baseline a run accepts
(item 11): a 10 % gain drift of a multi-plant batch is one headline row per record, on
its recommended model, with the per-method detail below, and the Summary says regressed."""

from __future__ import annotations

import json
import re
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest
from typer.testing import CliRunner

from pipeline.cli.commands import app
from pipeline.errors import UserError
from pipeline.gate.baseline import Tolerances, compare
from pipeline.gate.baseline_file import check_baseline
from pipeline.gate.findings import Comparison, Finding
from pipeline.report.regressions import gate_lines, regression_section
from pipeline.results import as_doc
from pipeline.synth.logs import write_synthetic_logs

runner = CliRunner()
N = 3


def _config(folder: Path, logs: Path) -> Path:
    c = folder / "plants.yaml"
    c.write_text(f"name: plants\ndata:\n  path: {logs}\n  input: u\n  output: y\n"
                 "  time: time\nmethods: all\nreport: {plots: none}\n")
    return c


def _rows(md: str, heading: str) -> list[list[str]]:
    """The body rows of the first Markdown table after ``heading``."""
    part = md[md.index(heading):].split("\n\n|", 1)[1]
    lines = ("|" + part).split("\n\n")[0].splitlines()[2:]
    return [[c.strip() for c in line.strip().strip("|").split("|")] for line in lines]


@pytest.fixture(scope="module")
def drifted(tmp_path_factory):
    """A batch of N synthetic plants, every method; then the same plants with a 10 % gain
    drift and fresh noise, run against the first as the baseline."""
    root = tmp_path_factory.mktemp("gate")
    write_synthetic_logs(root / "base", N, seed=3)
    write_synthetic_logs(root / "drift", N, seed=3, noise_seed=98, gain_drift=0.10)
    r = runner.invoke(app, ["run", str(_config(root, root / "base")), "--out",
                               str(root / "r0"), "--workers", "1"])
    assert r.exit_code == 0, r.output
    r = runner.invoke(app, ["run", str(_config(root, root / "drift")), "--out",
                               str(root / "r1"), "--workers", "1", "--baseline",
                               str(root / "r0" / "results.json"), "--junit",
                               str(root / "junit.xml")])
    return root, r


def test_one_headline_row_per_regressed_record_on_its_recommended_model(drifted):
    root, r = drifted
    assert r.exit_code == 1, r.output
    doc = json.loads((root / "r1" / "results.json").read_text())
    base = json.loads((root / "r0" / "results.json").read_text())
    comparison = compare(doc, base)
    n_findings = len(comparison.regressions)
    # the gate is on the recommended model: its gain on every record; the drift moves
    # every other method's gain too, listed for information (regressions with --gate all)
    assert n_findings >= N and all(
        (f.event, f.method) == comparison.recommended[f.record] for f in comparison.regressions)
    assert {f.record for f in comparison.regressions if f.parameter == "K"} == {
        f"log_{i:03d}" for i in range(N)}
    assert len(comparison.other) >= 8 * N
    assert len(compare(doc, base, Tolerances(scope="all")).regressions) >= 9 * N
    md = (root / "r1" / "report.md").read_text()
    headline = _rows(md, "## Regressions against the baseline")
    assert len(headline) == N  # one row per record, not one per method
    recommended = {rec["name"]: rec["recommended"]["method"] for rec in doc["records"]}
    for row in headline:
        name = re.sub(r"\[(.*)\]\(.*\)", r"\1", row[0])
        assert row[1].startswith(f"`{recommended[name]}`")
        assert row[2] == "K" and 8.0 < float(row[5].split()[0]) < 12.0 and row[6] == "5.0 %"
    detail = _rows(md, "### Every regression, per method")
    assert len(detail) == n_findings
    assert f"{N} record(s) regressed ({n_findings} finding(s) on the recommended models)" in md
    assert len(_rows(md, "### Other methods, for information")) == len(comparison.other)
    summary = _rows(md, "## Summary")
    assert [row[2] for row in summary] == ["**regressed**"] * N  # beside the verdict
    html = (root / "r1" / "report.html").read_text()
    gate = html[html.index('id="regressions"'):html.index('id="summary"')]
    assert gate.count("<details>") == 2 and gate.count('<span class="badge') == 0
    assert html.count('class="badge v-regressed"') == N
    # the terminal: one line for the gate, one per record
    lines = [ln for ln in r.stdout.splitlines() if "regress" in ln or ln.startswith("  log_")]
    assert lines[0].startswith(f"{N} record(s) regressed against")
    assert sum(ln.startswith("  log_") for ln in lines) == N
    assert all("(recommended)" in ln and " K " in ln for ln in lines[1:])
    # JUnit: each failure says whether it is on the recommended model
    messages = [f.get("message") for f in ET.parse(root / "junit.xml").iter("failure")]
    assert len(messages) == n_findings
    assert all("(recommended model)" in m for m in messages)


def _f(record, method, parameter="K", change=0.1, kind="param_drift", event=0):
    return Finding(record, event if method else None, method, kind, parameter, 1.0,
                   1.0 + (change or 0), change, 0.05 if change is not None else None,
                   f"{record} {method} {parameter}")


def test_headline_rules():
    c = Comparison(regressions=(
        _f("a", "smith", change=0.30), _f("a", "first_order", "T", change=0.2),
        _f("a", "first_order", change=0.07),                  # recommended: K and T
        _f("b", "smith", change=0.5), _f("b", "latzel", change=0.06),  # not on the model
        _f("c", "first_order"), _f("c", None, "status", None, kind="missing"),
    ), recommended={"a": (0, "first_order"), "b": (0, "first_order"),
                    "c": (0, "first_order")})
    a, b, cc = c.by_record()
    assert (a.headline.parameter, a.headline.method, a.on_recommended) == ("T", "first_order",
                                                                           True)
    assert len(a.on_model) == 2 and a.other_methods == 1
    assert (b.headline.method, b.on_recommended) == ("smith", False)  # worst of the others
    assert cc.headline.kind == "missing" and not cc.on_recommended
    section = regression_section(c)
    assert len(section.headline.rows) == 3 and len(section.detail.rows) == 7
    assert section.headline.rows[0][7].text == "K +7.0 %; 1 other method(s) regressed too"
    assert "not the recommended model" in section.headline.rows[1][2].note
    lines = gate_lines(c, "b.json", limit=2)
    assert lines[0].startswith("3 record(s) regressed against b.json (7 finding(s)")
    assert lines[1].startswith("  a: first_order (recommended) T 1 -> 1.2 +20.0 %")
    assert lines[2].startswith("  b: smith (recommended: first_order) K")
    assert lines[-1] == "  ... and 1 more record(s)"
    assert gate_lines(Comparison(), "b.json") == ["no regression against b.json (0 new, "
                                                  "0 missing)"]


# -- which baseline a run accepts ---------------------------------------------------------

def _doc(config="configs/plant.yaml", records=("a", "b"), method="first_order"):
    return as_doc({"pipeline_version": "1", "config": config, "records": [
        {"name": n, "source": f"{n}.csv", "status": "ok",
         "fits": [{"method": method, "event": 0, "status": "ok"}]} for n in records]})


def test_a_baseline_of_the_same_config_elsewhere_and_overlapping_records_is_accepted():
    doc = _doc()
    assert check_baseline(doc, "b.json", config="/ci/x/configs/plant.yaml", records=["b", "c"],
                          methods=["first_order", "smith"]) is doc
    assert check_baseline(_doc(config=""), "b.json", config="other.yaml") is not None
    # the baseline's record the run does not have: missing (a regression, it was ok)
    missing = compare(_doc(records=("b", "c")), doc).missing
    assert [f.record for f in missing] == ["a"]


@pytest.mark.parametrize("kwargs, needle", [
    ({"config": "configs/other.yaml"}, "a baseline of config 'configs/plant.yaml', not of this "
                                       "run's 'configs/other.yaml'"),
    ({"records": ["x", "y"]}, "shares no record with this run (baseline: 'a', 'b'; this run: "
                              "'x', 'y')"),
    ({"methods": ["smith"]}, "no fit in the baseline is of a method this config runs"),
])
def test_a_baseline_of_another_config_is_refused(kwargs, needle):
    with pytest.raises(UserError) as exc:
        check_baseline(_doc(), "b.json", **kwargs)
    assert exc.value.message.startswith("b.json: ") and needle in exc.value.message
