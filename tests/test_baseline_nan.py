"""A baseline with a NaN parameter is refused (issue 31: NaN compares false with
everything, so the gate was off and a doubled gain passed with exit 0); a baseline with
numbers still gates (the twin: the doubled gain is a regression)."""

from __future__ import annotations

import json

from typer.testing import CliRunner

from pipeline.cli.commands import app
from tests.test_cli import _csv

runner = CliRunner()


def _config(tmp_path, log):
    cfg = tmp_path / "c.yaml"
    cfg.write_text(f"name: x\ndata:\n  path: {log}\n  input: u\n  output: y\n  time: time\n"
                   "methods: [lsq_first_order]\nreport: {plots: none}\n")
    return cfg


def test_a_nan_baseline_is_refused_and_a_number_still_gates(tmp_path):
    log = _csv(tmp_path, "log.csv")
    cfg = _config(tmp_path, log)
    r = runner.invoke(app, ["run", str(cfg), "--out", str(tmp_path / "night1")])
    assert r.exit_code == 0, r.output
    doc = json.loads((tmp_path / "night1" / "results.json").read_text())
    doc["records"][0]["recommended"]["params"]["K"] *= 0.5  # tonight's gain doubles
    for fit in doc["records"][0]["fits"]:
        if fit.get("params"):
            fit["params"]["K"] *= 0.5
    good = tmp_path / "half.json"
    good.write_text(json.dumps(doc))
    r = runner.invoke(app, ["run", str(cfg), "--out", str(tmp_path / "n2"), "--baseline",
                            str(good)])
    assert r.exit_code == 1, r.output  # the twin: a baseline of numbers gates
    doc["records"][0]["recommended"]["params"]["K"] = float("nan")
    bad = tmp_path / "nan.json"
    bad.write_text(json.dumps(doc))  # json writes NaN, and reads it back
    r = runner.invoke(app, ["run", str(cfg), "--out", str(tmp_path / "n3"), "--baseline",
                            str(bad)])
    assert r.exit_code == 2, r.output
    (line,) = r.stderr.strip().splitlines()
    assert "parameter 'K' is nan" in line and "the recommended model" in line
    r = runner.invoke(app, ["baseline", "accept", str(bad), "--to", str(tmp_path / "b.json")])
    assert r.exit_code == 2 and not (tmp_path / "b.json").exists()
