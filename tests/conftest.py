import json
import os
from functools import cache
from pathlib import Path

import pytest

from pipeline.schema import READABLE_VERSIONS

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


@cache
def results_schema() -> dict:
    from pipeline.schema import json_schema

    return json_schema()


def validate_results_files(folder: Path) -> int:
    """Validate every results.json below ``folder`` against ``pipeline schema``; how many."""
    import jsonschema

    n = 0
    for path in folder.rglob("results.json"):
        doc = json.loads(path.read_text(encoding="utf-8"))
        jsonschema.validate(doc, results_schema())
        assert doc["schema_version"] in READABLE_VERSIONS, path  # hand-made baselines: 2
        n += 1
    return n


@pytest.fixture(autouse=True, scope="session")
def _every_results_json_validates(tmp_path_factory):
    """Every results.json any test writes validates against the shipped JSON Schema."""
    yield
    validate_results_files(tmp_path_factory.getbasetemp())
