"""What the report header and a record's source line show (issue 29): the time to the
second with its zone, a fetched dataset by name, not the cache path of the machine."""

from __future__ import annotations

from pipeline.io.datasets import CACHE_ENV, shown_source
from pipeline.report.build import shown_time


def test_time_to_the_second_with_its_zone():
    assert shown_time("2026-12-06T13:21:18.286597+00:00") == "2026-12-06 13:21:18 UTC"
    assert shown_time("2026-12-06T13:21:18") == "2026-12-06 13:21:18"
    assert shown_time("yesterday") == "yesterday"


def test_a_dataset_by_name_a_working_file_relative(tmp_path, monkeypatch):
    cache = tmp_path / "cache"
    monkeypatch.setenv(CACHE_ENV, str(cache))
    assert (shown_source(str(cache / "daisy-heating" / "heating_system.dat"))
            == "dataset daisy-heating: heating_system.dat")
    work = tmp_path / "work"
    (work / "logs").mkdir(parents=True)
    monkeypatch.chdir(work)
    assert shown_source(str(work / "logs" / "a.csv")) == "logs/a.csv"
    elsewhere = str(tmp_path / "other" / "b.csv")
    assert shown_source(elsewhere) == elsewhere
    assert shown_source("identify x") == "identify x"  # not a path: as given
