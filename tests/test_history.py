"""Run history: five nights of a drifting plant appended to parquet, trends and plots."""

from __future__ import annotations

import os
import stat
from datetime import UTC, datetime, timedelta, timezone
from io import BytesIO

import numpy as np
import polars as pl
import pytest
from matplotlib.image import imread

from pipeline.errors import UserError
from pipeline.gate.history import (
    SCHEMA,
    append_history,
    history_rows,
    load_history,
    run_times,
)
from pipeline.models import PARAMETERS
from pipeline.record import make_record
from pipeline.report.history_plots import history_figures, plot_frame, recommended_rows
from pipeline.results import as_doc
from pipeline.synth.logs import plan_logs, write_nights

from .test_baseline import failed_record, fit_record

NIGHTS = 5
DRIFT = 0.02
METHODS = ("first_order", "viteckova1")
START = datetime(2024, 3, 1, 2, 0, tzinfo=UTC)


def night_results(folder, night: int) -> dict:
    """results.json of one night, fitted from the CSV files the night wrote."""
    records = []
    for path in sorted(folder.glob("*.csv")):
        f = pl.read_csv(path)
        rec = make_record(f["time"].to_numpy(), f["u"].to_numpy(), f["y"].to_numpy(),
                          name=path.stem, source=str(path))
        records.append(recommending(fit_record(rec, METHODS)))
    return as_doc({"pipeline_version": "0.1.0", "config": "configs/nightly.yaml",
                   "created": (START + timedelta(days=night)).isoformat(), "records": records})


def recommending(record: dict) -> dict:
    """A record document that recommends its first method's fit (as pipeline writes them;
    ``fit_record`` writes the ranked-best field of older documents instead)."""
    best = record.pop("best")
    fit = next(f for f in record["fits"] if f["method"] == best["method"])
    return {**record, "recommended": {"method": fit["method"], "event": fit["event"],
                                      "structure": fit["structure"], "params": fit["params"],
                                      "ci95": fit["ci95"], "reason": "test"}}


@pytest.fixture(scope="module")
def history(tmp_path_factory):
    root = tmp_path_factory.mktemp("nights")
    dirs = write_nights(root / "logs", nights=NIGHTS, drift_per_night=DRIFT, n=2, seed=3)
    path = root / "history" / "history.parquet"
    for k, folder in enumerate(dirs):
        append_history(path, night_results(folder, k), START + timedelta(days=k))
    return path


def test_five_nights_five_run_times(history):
    df = load_history(history)
    assert run_times(df) == [START + timedelta(days=k) for k in range(NIGHTS)]
    assert df.height == NIGHTS * 2 * len(METHODS)
    assert set(df.columns) >= {"time", "record", "event", "method", "status", *PARAMETERS,
                               "mse_validation", "mse_identification", "ise",
                               "fit_percent", "pipeline_version"}
    assert df.schema["time"] == pl.Datetime("us", "UTC")
    first = df.filter(pl.col("method") == "first_order")
    assert first.get_column("T1").is_null().all() and first.get_column("K").is_not_null().all()
    assert not [p for p in history.parent.iterdir() if p.name.endswith(".tmp")]


def test_gain_trend_follows_the_drift(history):
    df = load_history(history)
    truth = {p.name: p.K for p in plan_logs(2, seed=3)}
    for (record, method), part in df.group_by("record", "method"):
        k = part.sort("time").get_column("K").to_numpy()
        assert np.all(np.diff(k) > 0), (record, method, k)
        slope = np.polyfit(np.arange(NIGHTS), k, 1)[0]
        assert slope / truth[record] == pytest.approx(DRIFT, abs=0.004)


def test_rows_of_a_failed_record_and_naive_times():
    doc = as_doc({"pipeline_version": "0.1.0",
                  "records": [failed_record("bad", "bad.csv: the file is empty")]})
    rows = history_rows(doc, datetime(2024, 1, 1, 3, 0))
    assert rows.height == 1 and rows.item(0, "status") == "failed"
    assert rows.item(0, "method") is None and rows.item(0, "event") is None
    assert rows.item(0, "time") == datetime(2024, 1, 1, 3, 0, tzinfo=UTC)
    plus2 = timezone(timedelta(hours=2))
    rows = history_rows(doc, datetime(2024, 1, 1, 5, 0, tzinfo=plus2))
    assert rows.item(0, "time") == datetime(2024, 1, 1, 3, 0, tzinfo=UTC)


def test_appends_to_a_file_with_fewer_columns(tmp_path, history):
    path = tmp_path / "old.parquet"
    load_history(history).select("time", "record", "method", "K").write_parquet(path)
    doc = as_doc({"pipeline_version": "0.2.0",
                  "records": [failed_record("bad", "bad.csv: the file is empty")]})
    df = append_history(path, doc, START + timedelta(days=9))
    assert df.height == NIGHTS * 2 * len(METHODS) + 1
    assert load_history(path).get_column("status").null_count() == NIGHTS * 2 * len(METHODS)


def test_unreadable_history_is_a_user_error(tmp_path):
    with pytest.raises(UserError, match="not found"):
        load_history(tmp_path / "none.parquet")
    bad = tmp_path / "bad.parquet"
    bad.write_bytes(b"not parquet at all")
    with pytest.raises(UserError, match="not a readable parquet"):
        load_history(bad)
    with pytest.raises(UserError):
        append_history(bad, as_doc({"pipeline_version": "0", "records": []}), START)
    assert bad.read_bytes() == b"not parquet at all"


def test_history_figures_are_pngs(history):
    figs = history_figures(load_history(history))
    titles = [t for t, _ in figs]
    assert titles == [f"{what} over runs, relative to the first run" for what in (
        "gain K", "time constant T", "dead time", "validation MSE")]
    for _, png in figs:
        assert png.startswith(b"\x89PNG\r\n\x1a\n")
        image = imread(BytesIO(png))
        assert image.shape[0] > 200 and image.shape[1] > 400
    one = history_figures(load_history(history), record="log_001", dpi=30)
    assert one[0][0] == "gain K over runs, relative to the first run: log_001"
    assert history_figures(load_history(history), record="nope") == []


def test_one_series_per_record_on_its_recommended_fit_normalised_to_the_first_run(history):
    """One series per record, on the fit each night recommended."""
    rows = recommended_rows(load_history(history))
    assert rows.height == NIGHTS * 2 and (rows.get_column("method") == METHODS[0]).all()
    frame, note = plot_frame(rows, "K", None, max_lines=12)
    assert note == "" and sorted(frame.get_column("record").unique()) == ["log_000", "log_001"]
    last = frame.group_by("record").agg(pl.col("ratio").first().alias("a"),
                                        pl.col("ratio").last().alias("b"))
    assert last.get_column("a").to_list() == [1.0, 1.0]
    assert last.get_column("b").to_numpy() == pytest.approx(1 + DRIFT * (NIGHTS - 1), abs=0.01)
    frame, note = plot_frame(rows, "K", None, max_lines=1)
    assert note == " (the 1 of 2 records that moved most)"


# -- item 19: the recommended method alternates between nights, the gain drifts ----------

def _alternating_history(nights: int = 6, drift: float = 0.03) -> pl.DataFrame:
    """Three plants, two methods each night; the recommended one alternates (first_order,
    then strejc's equal lags), plant p0's gain drifts by ``drift`` per night, the methods'
    gains differ by 1 % (as two methods do on one log)."""
    rows = []
    for night in range(nights):
        t = START + timedelta(days=night)
        for p, k0 in enumerate((2.0, 0.5, 8.0)):
            k = k0 * (1 + drift * night) if p == 0 else k0
            for method, structure, factor, params in (
                    ("first_order", "first_order", 1.0, {"T": 5.0, "delay": 0.5}),
                    ("strejc", "n_lags", 1.01, {"T": 2.5, "n": 2.0, "delay": 0.2})):
                rows.append({"time": t, "record": f"p{p}", "event": 0, "method": method,
                             "status": "ok", "structure": structure, "verdict": "ok",
                             "best": (night % 2 == 0) == (method == "first_order"),
                             "recommended": (night % 2 == 0) == (method == "first_order"),
                             "K": k * factor, **params,
                             "mse_validation": 0.01 * (1 + night % 2),
                             "pipeline_version": "x"})
    # "best": the ranked-best mark of histories written before pipeline 0.3
    return pl.DataFrame(rows, schema_overrides={c: SCHEMA.get(c, pl.Boolean())
                                                for c in rows[0]})


def test_alternating_recommended_method_one_series_per_record_drift_as_ratio():
    df = _alternating_history()
    rows = recommended_rows(df)
    assert rows.height == 6 * 3 and set(rows.get_column("method")) == {"first_order", "strejc"}
    frame, note = plot_frame(rows, "K", None, max_lines=12)
    assert note == "" and frame.get_column("record").n_unique() == 3  # was 6 series
    ratio = {r: part.sort("time").get_column("ratio").to_numpy()
             for (r,), part in frame.group_by("record")}
    assert ratio["p0"][-1] == pytest.approx(1.15 * 1.01)  # the drift (night 5: strejc, +1 %)
    for steady in ("p1", "p2"):  # the method change is a 1 % wiggle, not a drift
        assert np.abs(ratio[steady] - 1).max() <= 0.0101
    # T means another thing for equal lags: only the nights of the first night's structure
    t, _ = plot_frame(rows, "T", None, max_lines=12)
    assert t.height == 3 * 3 and (t.get_column("ratio") == 1.0).all()
    # the dead time (0.5 s, then 0.2 s) is measured against the time scale, never /0
    delay, _ = plot_frame(rows, "delay", None, max_lines=12)
    assert np.isfinite(delay.get_column("ratio").to_numpy()).all()
    # with more records than lines, the drifted one stays
    frame, note = plot_frame(rows, "K", None, max_lines=1)
    assert frame.get_column("record").unique().to_list() == ["p0"]
    assert note == " (the 1 of 3 records that moved most)"
    titles = [t for t, _ in history_figures(df, dpi=30)]
    assert titles[0] == "gain K over runs, relative to the first run"
    assert "validation MSE over runs, relative to the first run" in titles


def test_a_history_written_before_0_3_is_appended_to_and_its_best_fits_drawn(tmp_path,
                                                                           history):
    """A file written before pipeline 0.3 has a ``best`` column (the ranked-best fit) and
    runs that named no recommended model: it is still appended to (the new rows leave
    ``best`` null), and its old runs are drawn on their best fit."""
    old = _alternating_history().with_columns(pl.lit(None, pl.Boolean()).alias("recommended"))
    path = tmp_path / "old.parquet"
    old.write_parquet(path)
    doc = night_results(sorted((history.parent.parent / "logs").glob("night_*"))[0], 0)
    df = append_history(path, doc, START + timedelta(days=30))
    assert df.height == old.height + history_rows(doc, START).height
    assert df.filter(pl.col("time") > START + timedelta(days=29)).get_column("best").is_null().all()
    assert recommended_rows(df).height == 6 * 3 + 2  # the old runs' best, the new ones'


def test_normalised_to_the_baseline_when_given():
    rows = recommended_rows(_alternating_history())
    ref = {"p0": ("first_order", {"K": 2.2, "T": 5.0, "delay": 0.5}, 0.01)}
    frame, _ = plot_frame(rows, "K", ref, max_lines=12)
    p0 = frame.filter(pl.col("record") == "p0").get_column("ratio").to_numpy()
    assert p0[0] == pytest.approx(2.0 / 2.2)
    p1 = frame.filter(pl.col("record") == "p1").get_column("ratio").to_numpy()
    assert p1[0] == 1.0  # not in the baseline: its first run


# -- item 13: a parquet file that is not our history is refused, untouched ---------------

@pytest.mark.parametrize("frame, needle", [
    (pl.DataFrame({"time": ["2024-01-01"], "record": ["a"], "method": ["m"]}),
     "column 'time' is String"),
    (pl.DataFrame({"time": [START], "record": [1], "method": ["m"]}), "column 'record' is Int64"),
    (pl.DataFrame({"time": [START], "record": ["a"], "method": ["m"], "temp": [1.0]}),
     "column 'temp' is not one of ours"),
    (pl.DataFrame({"time": [START], "record": ["a"]}), "no column 'method'"),
    (pl.DataFrame({"time": [START.replace(tzinfo=None)], "record": ["a"], "method": ["m"]}),
     "column 'time' is Datetime"),
])
def test_a_foreign_parquet_is_refused_and_kept(tmp_path, frame, needle):
    path = tmp_path / "foreign.parquet"
    frame.write_parquet(path)
    before = path.read_bytes()
    with pytest.raises(UserError, match="not a pipeline history file") as exc:
        append_history(path, as_doc({"pipeline_version": "0", "records": []}), START)
    assert needle in exc.value.message and str(path) in exc.value.message
    assert path.read_bytes() == before


def test_appending_keeps_the_file_mode(tmp_path, history):
    path = tmp_path / "shared.parquet"
    path.write_bytes(history.read_bytes())
    os.chmod(path, 0o664)
    doc = as_doc({"pipeline_version": "0", "records": [failed_record("bad", "empty")]})
    append_history(path, doc, START + timedelta(days=30))
    assert stat.S_IMODE(os.stat(path).st_mode) == 0o664
    assert load_history(path).height == NIGHTS * 2 * len(METHODS) + 1


def test_trend_titles_fit_and_twelve_records_get_twelve_colours():
    """Issue 29: a long title (a record name and the "moved most" note) wraps inside the
    figure instead of running off it; twelve records get twelve distinct colours, named
    in a legend beside the axes."""
    from datetime import datetime, timedelta

    import polars as pl

    from pipeline.report.history_plots import trend_figure

    t0 = datetime(2026, 12, 1)
    names = [f"district_heating_pipe_segment_{k:02d}" for k in range(12)]
    frame = pl.DataFrame({
        "time": [t0 + timedelta(days=d) for _ in names for d in range(4)],
        "record": [n for n in names for _ in range(4)],
        "ratio": [1.0 + 0.01 * k * d for k in range(12) for d in range(4)]})
    title = ("time constant T over runs, relative to the baseline: " + names[0]
             + " (the 12 of 40 records that moved most)")
    fig = trend_figure(frame, title, "T", "the baseline")
    fig.canvas.draw()
    ax = fig.axes[0]
    box = ax.title.get_window_extent()
    width, height = fig.canvas.get_width_height()
    assert box.x0 >= 0 and box.x1 <= width and box.y1 <= height
    assert "\n" in ax.title.get_text()
    colours = {tuple(line.get_color()) for line in ax.get_lines()[1:]}
    assert len(ax.get_lines()) - 1 == 12 and len(colours) == 12
    assert [x.get_text() for x in ax.get_legend().get_texts()] == names


def test_a_title_of_any_length_draws():
    """The review's case: a 1,300-character title pushed the top margin below the bottom
    one (ValueError); it is cut to four lines."""
    from datetime import datetime, timedelta

    import polars as pl

    from pipeline.report.history_plots import trend_figure

    t0 = datetime(2026, 12, 1)
    frame = pl.DataFrame({"time": [t0 + timedelta(days=d) for d in range(3)],
                          "record": ["r"] * 3, "ratio": [1.0, 1.1, 1.2]})
    fig = trend_figure(frame, "a_long_record_name " * 70, "K", "the baseline")
    assert fig.axes[0].title.get_text().count("\n") == 3
