import os
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
SHARED = ROOT.parent / "shared" / "datasets"


@pytest.fixture(autouse=True)
def _mirror(monkeypatch, tmp_path_factory):
    """Datasets come from the mirror (CI sets it; default ../shared/datasets) into a
    per-session cache, never from the network in tests."""
    mirror = os.environ.get("PIPELINE_DATASETS_MIRROR") or str(SHARED)
    monkeypatch.setenv("PIPELINE_DATASETS_MIRROR", str(Path(mirror).resolve()))
    cache = tmp_path_factory.getbasetemp() / "dataset-cache"
    monkeypatch.setenv("PIPELINE_DATASETS_CACHE", str(cache))


def have_mirror() -> bool:
    mirror = os.environ.get("PIPELINE_DATASETS_MIRROR") or str(SHARED)
    return (Path(mirror) / "daisy" / "heating_system.dat").is_file()
