"""``pipeline run CONFIG --check`` and ``pipeline schema --config`` (issue 29): a config,
its files and their columns checked without identifying anything; the config's JSON
Schema for an editor."""

from __future__ import annotations

import json

from typer.testing import CliRunner

from pipeline.cli.check import check_config
from pipeline.cli.commands import app
from tests.test_cli import _csv

runner = CliRunner()


def _config(tmp_path, paths, input_col="u"):
    cfg = tmp_path / "c.yaml"
    listed = "".join(f"    - {p}\n" for p in paths)
    cfg.write_text(f"name: x\ndata:\n  paths:\n{listed}  input: {input_col}\n  output: y\n"
                   "  time: time\nmethods: [first_order]\n")
    return cfg


def test_check_loads_every_file_and_writes_nothing(tmp_path):
    logs = [_csv(tmp_path, "a.csv"), _csv(tmp_path, "b.csv")]
    cfg = _config(tmp_path, logs)
    before = sorted(p.name for p in tmp_path.iterdir())
    r = runner.invoke(app, ["run", str(cfg), "--check", "--out", str(tmp_path / "out")])
    assert r.exit_code == 0, r.output
    lines = r.stdout.strip().splitlines()
    assert len(lines) == 2
    # 2137 rows at dt 0.1 from t = 0 (the synthetic log of tests/test_cli.py).
    assert all("ok, 2138 samples over 213.7 s" in ln for ln in lines), lines
    assert sorted(p.name for p in tmp_path.iterdir()) == before  # no report, no out folder


def test_check_names_the_bad_record_and_exits_3(tmp_path):
    good = _csv(tmp_path, "a.csv")
    bad = tmp_path / "b.csv"
    bad.write_text("time,v,y\n0,1,2\n1,1,2\n")
    code, rows = check_config(_config(tmp_path, [good, bad]))
    assert code == 3
    assert rows[0].error is None and rows[0].samples == 2138
    assert "no column 'u'" in rows[1].error
    r = runner.invoke(app, ["run", str(_config(tmp_path, [good, bad])), "--check"])
    assert r.exit_code == 3
    assert "b: " in r.stderr and "no column 'u'" in r.stderr
    assert "Traceback" not in r.output


def test_check_exits_2_when_no_record_loads_or_the_config_is_bad(tmp_path):
    log = _csv(tmp_path, "a.csv")
    code, rows = check_config(_config(tmp_path, [log], input_col="U"))
    assert code == 2 and "(did you mean 'u'?)" in rows[0].error
    cfg = tmp_path / "bad.yaml"
    cfg.write_text("name: x\ndata:\n  path: a.csv\n  inptu: u\n  output: y\n")
    r = runner.invoke(app, ["run", str(cfg), "--check"])
    assert r.exit_code == 2
    assert "unknown key 'data.inptu'" in r.stderr


def test_config_schema_is_json_schema_of_the_user_keys():
    r = runner.invoke(app, ["schema", "--config"])
    assert r.exit_code == 0, r.output
    schema = json.loads(r.stdout)
    props = schema["properties"]
    assert {"data", "methods", "tuning", "identification", "report"} <= set(props)
    assert "base_dir" not in props and "source" not in props
    assert schema["title"] == "pipeline run config"
