"""Run history: five nights of a drifting plant appended to parquet, trends and plots."""

from __future__ import annotations

from datetime import UTC, datetime, timedelta, timezone
from io import BytesIO

import numpy as np
import polars as pl
import pytest
from matplotlib.image import imread

from pipeline.errors import UserError
from pipeline.history import PARAMS, append_history, history_rows, load_history, run_times
from pipeline.record import make_record
from pipeline.report.history_plots import history_figures, plot_frame
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
        records.append(fit_record(rec, METHODS))
    return as_doc({"pipeline_version": "0.1.0", "config": "configs/nightly.yaml",
                   "created": (START + timedelta(days=night)).isoformat(), "records": records})


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
    assert set(df.columns) >= {"time", "record", "event", "method", "status", *PARAMS,
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
    assert titles == ["gain K over runs", "time constant T (s) over runs",
                      "dead time (s) over runs", "validation MSE over runs"]
    for _, png in figs:
        assert png.startswith(b"\x89PNG\r\n\x1a\n")
        image = imread(BytesIO(png))
        assert image.shape[0] > 200 and image.shape[1] > 400
    one = history_figures(load_history(history), record="log_001", dpi=30)
    assert one[0][0] == "gain K over runs: log_001"
    assert history_figures(load_history(history), record="nope") == []


def test_one_series_per_record_and_method_and_fallback_to_best_fits(history):
    df = load_history(history)
    frame, note = plot_frame(df, None, max_lines=12)
    assert note == "" and sorted(frame.get_column("series").unique()) == [
        f"log_00{i} / {m}" for i in range(2) for m in METHODS]
    frame, note = plot_frame(df, None, max_lines=2)
    assert note == " (best fits)" and frame.get_column("best").all()
    assert frame.get_column("series").n_unique() == 2
    frame, note = plot_frame(df, None, max_lines=1)
    assert note == " (best fits) (first 1 of 2 series)"
    assert frame.get_column("series").unique().to_list() == ["log_000 / first_order"]
