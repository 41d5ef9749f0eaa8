"""The report: it leads with the answer, shows units, and shows times in the user's unit."""

from __future__ import annotations

import pytest

from pipeline.analysis import AnalysisOptions, analyse
from pipeline.models import ProcessModel
from pipeline.record import make_record
from pipeline.report.build import render
from pipeline.report.tables import params_text, summary_table
from pipeline.results import RunResult
from pipeline.synth import step_record

PLANT = ProcessModel("first_order", {"K": 2.0, "T": 600.0, "delay": 60.0})


def _run(units: dict[str, str]) -> RunResult:
    rec = step_record(PLANT, u0=1.0, changes=[(1200.0, 3.0), (9000.0, 2.0)], t_end=16000.0,
                      dt=10.0, y0=5.0, noise=0.005, seed=1)
    rec = make_record(rec.t, rec.u, rec.y, name="slow", source="<slow>", units=units)
    return RunResult([analyse(rec, AnalysisOptions(methods=("first_order",)))], config="t")


def test_times_in_the_users_unit():
    run = _run({"time": "min", "input": "%", "output": "degC"})
    md, html, _ = render(run, run.to_doc(), title="t", plots_mode="none")
    # T = 600 s is 10 min, the delay 60 s is 1 min; the event starts at 20 min
    assert "| time constant T | 10." in md and "sample time 0.1667 min" in md
    row = summary_table(run.records, ["slow"]).rows[0]
    assert row[5].text.startswith("T=") and row[5].text.endswith("min")
    T = float(row[5].text.split("=")[1].split()[0])
    assert T == pytest.approx(10.0, rel=0.05)
    assert "t0 [min]" in md and "| 20 |" in md
    assert "degC/%" in md


def test_params_text_converts_with_the_units():
    p = {"K": 0.5, "T": 120.0, "delay": 30.0}
    assert params_text(p, {"time": "min", "input": "V", "output": "cm"}, "integrator_lag") == \
        "K=30 cm/V/min, T=2 min, delay=0.5 min"
    assert params_text(p) == "K=0.5, T=120, delay=30"


def test_report_leads_with_the_model_and_its_verdict():
    run = _run({"time": "s", "input": "V", "output": "degC"})
    md, html, _ = render(run, run.to_doc(), title="t", plots_mode="none")
    box = md.index("model: **")
    assert box < md.index("### Events") < md.index("### Models identified")
    assert 'class="badge v-' in html and "G(s) = " in html
    assert "K in degC/V" in md
