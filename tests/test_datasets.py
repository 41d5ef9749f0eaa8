"""Dataset registry: mirror, cache, sha256 check, clear error when unavailable."""

import pytest

from pipeline.errors import UserError
from pipeline.io import datasets
from tests.conftest import have_mirror

pytestmark = pytest.mark.skipif(not have_mirror(), reason="needs ../shared/datasets mirror")


def test_registry_lists_both_datasets_with_provenance():
    reg = datasets.load_registry()
    assert {"daisy-heating", "tclab-kantor"} <= set(reg)
    d = reg["daisy-heating"]
    assert d.url.startswith("ftp://ftp.esat.kuleuven.be/") and d.compression == "gzip"
    assert d.initial_input == 6.0 and d.citation


def test_fetch_from_mirror_then_cache(monkeypatch):
    p = datasets.fetch("daisy-heating")
    assert datasets.sha256_of(p) == datasets.dataset("daisy-heating").sha256
    monkeypatch.setenv(datasets.MIRROR_ENV, "/nonexistent")
    assert datasets.fetch("daisy-heating", offline=True) == p  # served from the cache


def test_corrupt_cache_is_replaced(monkeypatch):
    p = datasets.fetch("tclab-kantor")
    p.write_text("tampered")
    p2 = datasets.fetch("tclab-kantor")
    assert datasets.sha256_of(p2) == datasets.dataset("tclab-kantor").sha256


def test_wrong_checksum_in_mirror_is_refused(tmp_path, monkeypatch):
    (tmp_path / "daisy").mkdir()
    (tmp_path / "daisy" / "heating_system.dat").write_text("0 1 2\n")
    monkeypatch.setenv(datasets.MIRROR_ENV, str(tmp_path))
    monkeypatch.setenv("PIPELINE_DATASETS_CACHE", str(tmp_path / "cache"))
    with pytest.raises(UserError, match="does not match"):
        datasets.fetch("daisy-heating")


def test_unavailable_dataset_says_how_to_get_it(tmp_path, monkeypatch):
    monkeypatch.setenv(datasets.MIRROR_ENV, str(tmp_path))
    monkeypatch.setenv("PIPELINE_DATASETS_CACHE", str(tmp_path / "cache"))
    with pytest.raises(UserError) as exc:
        datasets.fetch("daisy-heating", offline=True)
    assert "PIPELINE_DATASETS_MIRROR" in exc.value.message
    assert "heating_system.dat.gz" in exc.value.message


def test_unknown_dataset():
    with pytest.raises(UserError, match="unknown dataset 'nope'"):
        datasets.dataset("nope")


def test_cached_copy_has_the_umasks_mode(tmp_path, monkeypatch):
    """A shared cache stays readable by the team: not mkstemp's private 0600 (issue 13)."""
    import os

    monkeypatch.setenv("PIPELINE_DATASETS_CACHE", str(tmp_path / "cache"))
    old = os.umask(0o022)
    try:
        p = datasets.fetch("daisy-heating")
    finally:
        os.umask(old)
    assert p.stat().st_mode & 0o777 == 0o644
