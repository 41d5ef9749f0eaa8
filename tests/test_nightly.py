"""Issue 5 end to end through the CLI: a batch with corrupt logs, the regression gate with
JUnit, and the history over five nights."""

import json
import xml.etree.ElementTree as ET
from pathlib import Path

import polars as pl
from typer.testing import CliRunner

from pipeline.cli.commands import app
from pipeline.synth.logs import write_nights, write_synthetic_logs

runner = CliRunner()
METHODS = "[first_order, first_order_two_point, viteckova1, sundaresan, latzel]"


def _config(folder: Path, logs: Path, plots: str = "none") -> Path:
    c = folder / "nightly.yaml"
    c.write_text(f"name: nightly\ndata:\n  path: {logs}\n  input: u\n  output: y\n"
                 f"  time: time\nmethods: {METHODS}\nreport: {{plots: {plots}}}\n")
    return c


def test_batch_with_corrupt_files_exit_3_and_complete_report(tmp_path):
    logs = tmp_path / "logs"
    write_synthetic_logs(logs, 50, seed=1, corrupt=10, delay=0.3)
    out = tmp_path / "out"
    r = runner.invoke(app, ["run", str(_config(tmp_path, logs)), "--out", str(out),
                            "--workers", "2"])
    assert r.exit_code == 3, r.output
    doc = json.loads((out / "results.json").read_text())
    status = [rec["status"] for rec in doc["records"]]
    assert status.count("ok") == 40 and status.count("failed") == 10
    failed = [rec for rec in doc["records"] if rec["status"] == "failed"]
    assert all(rec["error"] and rec["name"] in rec["error"] or rec["source"] in rec["error"]
               for rec in failed)
    html = (out / "report.html").read_text()
    for rec in failed:
        assert rec["name"] in html
    assert html.count('class="failed"') >= 10
    assert len(r.stderr.strip().splitlines()) == 10  # one line per bad log
    r2 = runner.invoke(app, ["run", str(_config(tmp_path, logs)), "--out", str(out),
                             "--workers", "1", "--allow-failures"])
    assert r2.exit_code == 0


def test_every_record_failing_is_exit_2_with_every_output(tmp_path):
    """Issue 13 item 12: CI sees a batch in which every record failed: results.json, the
    report listing each failure, the JUnit file and the history rows, and exit 2."""
    logs = tmp_path / "logs"
    write_synthetic_logs(logs, 3, corrupt=3)
    out, junit, history = tmp_path / "out", tmp_path / "j.xml", tmp_path / "h.parquet"
    r = runner.invoke(app, ["run", str(_config(tmp_path, logs)), "--out", str(out),
                            "--workers", "1", "--junit", str(junit), "--history",
                            str(history)])
    assert r.exit_code == 2, r.output
    assert len(r.stderr.strip().splitlines()) == 3  # one line per bad log
    doc = json.loads((out / "results.json").read_text())
    assert [rec["status"] for rec in doc["records"]] == ["failed"] * 3
    html, md = (out / "report.html").read_text(), (out / "report.md").read_text()
    for rec in doc["records"]:
        assert rec["name"] in html and rec["name"] in md
    assert html.count('class="failed"') >= 3
    root = ET.parse(junit).getroot()
    assert root.get("tests") == "3" and root.get("errors") == "3"
    rows = pl.read_parquet(history)
    assert rows.height == 3 and rows["status"].to_list() == ["failed"] * 3


def test_regression_gate_drift_flagged_fresh_noise_not(tmp_path):
    base_logs, same, drift = tmp_path / "base", tmp_path / "same", tmp_path / "drift"
    write_synthetic_logs(base_logs, 4, seed=3, delay=0.3)
    write_synthetic_logs(same, 4, seed=3, delay=0.3, noise_seed=99)  # fresh noise only
    write_synthetic_logs(drift, 4, seed=3, delay=0.3, noise_seed=98, gain_drift=0.10)
    r = runner.invoke(app, ["run", str(_config(tmp_path, base_logs)), "--out",
                            str(tmp_path / "r0"), "--workers", "1"])
    assert r.exit_code == 0, r.output
    baseline = tmp_path / "baseline.json"
    r = runner.invoke(app, ["baseline", "accept", str(tmp_path / "r0" / "results.json"),
                            "--to", str(baseline)])
    assert r.exit_code == 0 and baseline.is_file()

    r = runner.invoke(app, ["run", str(_config(tmp_path, same)), "--out", str(tmp_path / "r1"),
                            "--workers", "1", "--baseline", str(baseline), "--junit",
                            str(tmp_path / "r1" / "junit.xml")])
    assert r.exit_code == 0, r.output
    assert (tmp_path / "r1" / "junit.xml").is_file()  # written after the report folder swap

    junit = tmp_path / "junit-drift.xml"
    r = runner.invoke(app, ["run", str(_config(tmp_path, drift)), "--out", str(tmp_path / "r2"),
                            "--workers", "1", "--baseline", str(baseline), "--junit",
                            str(junit)])
    assert r.exit_code == 1, r.output
    tree = ET.parse(junit).getroot()
    # every fit's testcase carries its measured time, within the run's
    cases = [c for c in tree.iter("testcase") if c.get("name", "").startswith("event ")]
    times = [float(c.get("time")) for c in cases]
    assert cases and all(t > 0 for t in times)
    assert sum(times) < float(tree.get("time"))
    failures = tree.iter("failure")
    texts = [f.get("message", "") + (f.text or "") for f in failures]
    assert texts and any("log_000" in t and "first_order" in t and " K" in t for t in texts)
    html = (tmp_path / "r2" / "report.html").read_text()
    assert html.index("Regressions against the baseline") < html.index("Summary")


def test_history_over_five_nights_shows_the_drift(tmp_path):
    nights = write_nights(tmp_path / "nights", nights=5, drift_per_night=0.03, n=2, seed=4,
                          delay=0.3)
    history = tmp_path / "history.parquet"
    for k, night in enumerate(nights):
        r = runner.invoke(app, ["run", str(_config(tmp_path, night)), "--out",
                                str(tmp_path / f"n{k}"), "--workers", "1", "--history",
                                str(history)])
        assert r.exit_code == 0, r.output
    df = pl.read_parquet(history)
    fo = df.filter((pl.col("method") == "first_order") & (pl.col("record") == "log_000")
                   & (pl.col("event") == 0)).sort("time")
    assert fo.height == 5
    k = fo["K"].to_list()
    assert k[-1] / k[0] > 1.09  # four nights of 3 % drift
    html = (tmp_path / "n4" / "report.html").read_text()
    assert '<h2 id="history">History</h2>' in html
    assert html[html.index('id="history"'):].count("data:image/png;base64,") >= 2
