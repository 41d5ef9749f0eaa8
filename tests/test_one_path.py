"""One analysis path: ``pipeline identify`` and ``pipeline run`` give the same fits."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from typer.testing import CliRunner

from pipeline.cli.commands import app
from pipeline.io.datasets import fetch
from tests.conftest import ROOT, have_mirror

runner = CliRunner()
JAKOUBEK = sorted((ROOT / "datasets" / "examples" / "jakoubek").glob("system*.csv"))


def _fits(doc: dict) -> list[tuple]:
    (rec,) = doc["records"]
    return [(f["event"], f["method"], f["status"], f["params"]) for f in rec["fits"]]


def _same(a: list[tuple], b: list[tuple]) -> None:
    assert [x[:3] for x in a] == [x[:3] for x in b]
    for (*_, pa), (*_, pb) in zip(a, b, strict=True):
        assert (pa is None) == (pb is None)
        for k, v in (pa or {}).items():
            assert pb[k] == pytest.approx(v, rel=1e-12, abs=1e-12), k


def _identify(*args: str) -> dict:
    r = runner.invoke(app, ["identify", *args, "--json"])
    assert r.exit_code == 0, r.output
    return json.loads(r.output)


def _run(tmp_path: Path, config: str) -> dict:
    cfg = tmp_path / "c.yaml"
    cfg.write_text(config)
    out = tmp_path / "out"
    r = runner.invoke(app, ["run", str(cfg), "--out", str(out), "--workers", "1"])
    assert r.exit_code == 0, r.output
    return json.loads((out / "results.json").read_text())


@pytest.mark.skipif(not have_mirror(), reason="needs ../shared/datasets mirror")
def test_daisy_identify_equals_run(tmp_path):
    ident = _identify(str(fetch("daisy-heating")), "--input", "u", "--output", "y", "--time",
                      "time", "--initial-input", "6")
    run = _run(tmp_path, "name: t\ndata: {dataset: daisy-heating, initial_input: 6.0}\n"
                         "report: {plots: none}\n")
    assert len(_fits(run)) == len(_fits(ident)) >= 11
    _same(_fits(ident), _fits(run))
    # no "needs an impulse event" rows for step-only methods: 'all' means the step methods
    assert all(f[2] != "not_applicable" or "needs" not in str(f) for f in _fits(run))


@pytest.mark.parametrize("path", JAKOUBEK, ids=lambda p: p.stem)
def test_jakoubek_identify_equals_run(tmp_path, path):
    ident = _identify(str(path), "--input", "u", "--output", "y", "--time", "time")
    run = _run(tmp_path, f"name: j\ndata:\n  path: {path}\n  input: u\n  output: y\n"
                         "  time: time\nreport: {plots: none}\n")
    _same(_fits(ident), _fits(run))


def test_explicit_method_lists_agree(tmp_path):
    path = JAKOUBEK[0]
    ident = _identify(str(path), "--input", "u", "--output", "y", "--time", "time",
                      "--method", "first_order,first_order_impulse", "--method", "latzel")
    run = _run(tmp_path, f"name: j\ndata:\n  path: {path}\n  input: u\n  output: y\n"
                         "  time: time\nmethods: [first_order, first_order_impulse, latzel]\n"
                         "report: {plots: none}\n")
    _same(_fits(ident), _fits(run))
    assert [f[1] for f in _fits(run)] == ["first_order", "first_order_impulse", "latzel"]
    assert _fits(run)[1][2] == "not_applicable"  # asked for by name: listed with its reason
