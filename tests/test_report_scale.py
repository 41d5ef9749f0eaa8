"""Reports at scale (issue 14 item 7): long curves decimated to the pixels they fill with
every column's minimum and maximum kept, and a 2000-event record's report readable (the
summary first, per-event detail folded in HTML, capped in Markdown)."""

from __future__ import annotations

import numpy as np
import pytest
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from pipeline.events import Event
from pipeline.record import make_record
from pipeline.report import plots
from pipeline.report.build import render
from pipeline.report.drawing import columns_of, decimate
from pipeline.report.sections import DETAILED_EVENTS, FOLD_ROWS
from pipeline.results import RecordResult, RunResult


def test_decimation_keeps_each_pixel_columns_min_and_max():
    rng = np.random.default_rng(3)
    n, columns = 1_000_003, 997
    x = np.sort(rng.uniform(0.0, 50.0, n))  # irregular sampling
    y = np.sin(x) + rng.normal(0, 0.1, n)
    spike = 123_457
    y[spike] = 9.0  # one-sample peaks survive
    y[spike + 300_000] = -7.0
    xd, yd = decimate(x, y, columns)
    assert xd.size <= 2 * columns and np.all(np.diff(xd) >= 0)
    col = np.minimum((x - x[0]) * (columns / (x[-1] - x[0])), columns - 1).astype(int)
    cold = np.minimum((xd - x[0]) * (columns / (x[-1] - x[0])), columns - 1).astype(int)
    lo = np.full(columns, np.inf)
    hi = np.full(columns, -np.inf)
    np.minimum.at(lo, col, y)
    np.maximum.at(hi, col, y)
    lo_d = np.full(columns, np.inf)
    hi_d = np.full(columns, -np.inf)
    np.minimum.at(lo_d, cold, yd)
    np.maximum.at(hi_d, cold, yd)
    assert np.array_equal(lo, lo_d) and np.array_equal(hi, hi_d)
    assert 9.0 in yd and -7.0 in yd
    short = np.arange(100.0)
    assert decimate(short, short, 60)[0].size == 100  # short curves drawn as they are


def test_decimation_keeps_gaps():
    x = np.arange(10_000.0)
    y = np.ones_like(x)
    y[4000:6000] = np.nan
    _, yd = decimate(x, y, 100)
    assert np.isnan(yd).sum() >= 10 and np.nanmax(yd) == 1.0


def _long_record(n: int):
    t = np.arange(n) * 0.01
    u = (np.floor(t / 50.0) % 2).astype(float)
    y = u + np.random.default_rng(0).normal(0, 0.01, n)
    return make_record(t, u, y, name="long", source="long.csv", units={"time": "s"})


def test_overview_of_a_long_record_plots_at_most_two_points_per_pixel(monkeypatch):
    rec = _long_record(1_000_000)
    drawn = []
    real = plots.decimate

    def spy(x, y, columns):
        out = real(x, y, columns)
        drawn.append((x.size, out[0].size, columns))
        return out

    monkeypatch.setattr(plots, "decimate", spy)
    png = plots.overview(rec, [], {}, dpi=50)
    assert png[:4] == b"\x89PNG"
    fig = Figure(figsize=(11, 5.2))
    FigureCanvasAgg(fig)
    width = columns_of(fig, 50)
    assert [d[0] for d in drawn] == [1_000_000, 1_000_000]
    assert all(d[2] == width and d[1] <= 2 * width for d in drawn)


def _events(rec, n: int) -> list[Event]:
    step = rec.n_samples // n
    out = []
    for k in range(n):
        i0, i1 = k * step, (k + 1) * step
        out.append(Event(index=k, kind="step", i_start=i0, i_end=i1, i_base=i0,
                         t0=float(rec.t[i0]), t_end=float(rec.t[i1 - 1]), u0=float(k % 2),
                         u_ss=float((k + 1) % 2), y0=0.0, y_ss=1.0))
    return out


@pytest.fixture(scope="module")
def report_2000():
    rec = _long_record(200_000)
    events = _events(rec, 2000)
    roles = {0: "identification", **{k: "validation" for k in range(1, 2000)}}
    res = RecordResult(name="long", source="long.csv", record=rec, events=events,
                       roles=roles)
    run = RunResult([res], config="c.yaml")
    return render(run, run.to_doc(), title="t", plots_mode="summary")


def test_a_2000_event_report_leads_with_the_summary_and_folds_the_events(report_2000):
    md, html, files = report_2000
    assert md.index("## Summary") < md.index("### Events")
    assert "2000 event(s): 2000 steps; 1 identification, 1999 validation" in md
    event_rows = [line for line in md[md.index("### Events"):].splitlines()
                  if line.startswith("| ") and line.split("|")[2].strip() == "step"]
    assert len(event_rows) == FOLD_ROWS
    assert f"{2000 - FOLD_ROWS} more rows" in md and "results.json" in md
    assert len(md) < 20_000
    # HTML: every event, folded
    details = html[html.index("<details>"):html.index("</details>")]
    assert "Every event: 2000 rows" in details and details.count("<tr>") == 2001
    assert list(files) == ["plots/long_overview.png"]


def test_identification_events_beyond_the_detailed_ones_get_one_row_each():
    rec = _long_record(20_000)
    events = _events(rec, 12)
    res = RecordResult(name="long", source="long.csv", record=rec, events=events,
                       roles={k: "identification" for k in range(12)})
    run = RunResult([res], config="c.yaml")
    md, html, _ = render(run, run.to_doc(), title="t", plots_mode="none")
    assert md.count("### Models identified on event") == DETAILED_EVENTS
    assert f"### Best models of the other {12 - DETAILED_EVENTS} identification events" in md
    rest = md[md.index("### Best models of the other"):]
    assert rest.count("| no model |") == 12 - DETAILED_EVENTS
