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
