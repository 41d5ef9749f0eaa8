"""What the report header and a record's source line show (issue 29): the time to the
second with its zone, a fetched dataset by name, not the cache path of the machine."""

from __future__ import annotations

from pipeline.io import shown_source
from pipeline.report.build import shown_time


def test_time_to_the_second_with_its_zone():
    assert shown_time("2026-12-06T13:21:18.286597+00:00") == "2026-12-06 13:21:18 UTC"
    assert shown_time("2026-12-06T13:21:18") == "2026-12-06 13:21:18"
    assert shown_time("yesterday") == "yesterday"


def test_a_dataset_by_name_a_working_file_relative(tmp_path, monkeypatch):
    cache = tmp_path / "cache"
    monkeypatch.setenv("PIPELINE_DATASETS_CACHE", str(cache))
    assert (shown_source(str(cache / "daisy-heating" / "heating_system.dat"))
            == "dataset daisy-heating: heating_system.dat")
    work = tmp_path / "work"
    (work / "logs").mkdir(parents=True)
    monkeypatch.chdir(work)
    assert shown_source(str(work / "logs" / "a.csv")) == "logs/a.csv"
    elsewhere = str(tmp_path / "other" / "b.csv")
    assert shown_source(elsewhere) == elsewhere
    assert shown_source("identify x") == "identify x"  # not a path: as given


def test_an_irregular_grid_has_a_median_interval_and_a_jitter():
    import numpy as np

    from pipeline.record import make_record

    rng = np.random.default_rng(3)
    n = 2001
    u = np.where(np.arange(n) > 500, 1.0, 0.0)
    regular = make_record(np.arange(n) * 0.5, u, u.copy(), name="r", source="r")
    assert regular.sampling() == (0.5, 0.0)
    dt = 0.5 * (1 + 0.04 * rng.standard_normal(n - 1))  # a logger's clock: 4 % jitter
    t = np.concatenate([[0.0], np.cumsum(dt)])
    rec = make_record(t, u, u.copy(), name="j", source="j")
    assert rec.sample_time is None
    median, jitter = rec.sampling()
    assert abs(median - 0.5) < 0.005 and abs(jitter - 0.04) < 0.004


def test_mse_carries_the_outputs_unit_squared():
    """Issue 29: "validation MSE 16.1" read as a bare number; with an output unit it is
    "16.1 degC^2" in the summary, the scores line and the ranking's column; without one,
    the number alone."""
    import numpy as np

    import pipeline
    from pipeline.models import ProcessModel
    from pipeline.record import make_record
    from pipeline.report.tables import ranking_table, scores_text, summary_table
    from pipeline.synth import step_record

    rec = step_record(ProcessModel("first_order", {"K": 2.0, "T": 5.0}), u0=1.0,
                      changes=[(10.0, 3.0), (60.0, 1.0)], t_end=110.0, dt=0.1, y0=6.0,
                      noise=0.02)
    with_units = make_record(rec.t, rec.u, rec.y, name="p", source="p.csv",
                             units={"input": "V", "output": "degC"})
    for r, unit in ((with_units, " degC^2"), (rec, "")):
        res = pipeline.analyse(r)
        cells = [c.text for c in summary_table([res], ["a"]).rows[0]]
        mse = cells[7]
        assert mse.endswith(unit) and np.isfinite(float(mse.split()[0]))
        assert ("validation MSE " in scores_text(res, res.recommended)) and (
            scores_text(res, res.recommended).endswith(unit) or not unit)
        header = ranking_table(res, 0).columns[5]
        assert header.endswith("[degC^2]") == bool(unit)
