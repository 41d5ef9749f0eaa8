"""Progress, logging and the batch's one pool (issue 13 item 21, issue 14 item 7):
``--verbose`` shows each record's stages and time, ``--quiet`` only errors, the summary
stays on stdout; the bar follows a record's stages and the report steps; the report's
plots use the batch's pool and nothing to draw uses none."""

from __future__ import annotations

import pytest
from typer.testing import CliRunner

import pipeline.batch.pool as pool
import pipeline.run
from pipeline.batch.progress import Stages, Tracker
from pipeline.cli.commands import app
from pipeline.config import load_config
from pipeline.run import process_record, resolve_specs, run_config
from pipeline.synth.logs import write_synthetic_logs

runner = CliRunner()


@pytest.fixture(scope="module")
def logs(tmp_path_factory):
    d = tmp_path_factory.mktemp("progress")
    write_synthetic_logs(d / "logs", 3, seed=5, n_steps=2, corrupt=1)
    return d


def _config(d, plots="none", path="logs"):
    cfg = d / f"p_{plots}.yaml"
    cfg.write_text(f"name: p\ndata:\n  path: {path}\n  input: u\n  output: y\n  time: time\n"
                   f"methods: [first_order]\nreport: {{plots: {plots}}}\n")
    return cfg


def test_verbose_shows_stages_and_times_quiet_only_errors(logs, tmp_path):
    cfg = _config(logs)
    v = runner.invoke(app, ["run", str(cfg), "--workers", "1", "--out", str(tmp_path / "v"),
                            "--verbose"])
    q = runner.invoke(app, ["run", str(cfg), "--workers", "1", "--out", str(tmp_path / "q"),
                            "--quiet"])
    n = runner.invoke(app, ["run", str(cfg), "--workers", "1", "--out", str(tmp_path / "n")])
    assert v.exit_code == q.exit_code == n.exit_code == 3  # one corrupt log
    good = [s.name for s in resolve_specs(load_config(cfg))]
    for name in good:
        assert f"pipeline: {name}: loading " in v.stderr
    assert v.stderr.count(" samples in ") == 2  # the corrupt one fails to load
    assert v.stderr.count(": done in ") == 2 and v.stderr.count(": failed in ") == 1
    assert "pipeline: report sections: " in v.stderr
    # --quiet: the failure's error line and nothing else; the default: no log lines either
    assert [ln.startswith("error: ") for ln in q.stderr.splitlines()] == [True]
    assert q.stderr == n.stderr
    # the summary stays on stdout, the same whatever the verbosity
    assert v.stdout.startswith("2 of 3 record(s) identified")
    assert v.stdout.replace("/v/", "/q/") == q.stdout


def test_quiet_and_verbose_together_is_a_user_error(logs):
    r = runner.invoke(app, ["run", str(_config(logs)), "--quiet", "--verbose"])
    assert r.exit_code == 2 and r.stderr.strip().count("\n") == 0
    assert "--quiet and --verbose" in r.stderr


def test_bar_follows_a_record_through_its_stages(logs):
    cfg = load_config(_config(logs))
    spec = [s for s in resolve_specs(cfg)][0]
    seen = []
    with Tracker(1, show=True) as tracker:
        tracker.stage = lambda text, f=tracker.stage: (seen.append(text), f(text))
        tracker.start(spec.name)
        tracker.done(process_record(spec, cfg), 0.1)
    assert seen == ["start", "load", "analyse"]


def test_report_steps_are_counted(capsys):
    with Stages(show=True) as stages:
        stages.step("report sections", total=3)
        assert list(stages.counting(map)(str, [1, 2, 3])) == ["1", "2", "3"]
        stages.step("JUnit")
    err = capsys.readouterr().err
    assert "report sections" in err and "3/3" in err and "JUnit" in err


@pytest.mark.parametrize(("plots", "pools"), [("none", 1), ("summary", 1)])
def test_one_pool_for_records_and_plots(tmp_path, monkeypatch, plots, pools):
    write_synthetic_logs(tmp_path / "logs", 8, seed=6, n_steps=2)
    started = []

    class Counting(pool.ProcessPoolExecutor):
        def __init__(self, *a, **k):
            started.append(1)
            super().__init__(*a, **k)

    monkeypatch.setattr(pool, "ProcessPoolExecutor", Counting)
    drawn = []
    real_map = pipeline.run.parallel_map

    def spy(pool, n, *a):
        drawn.append(pool is not None)
        return real_map(pool, n, *a)

    monkeypatch.setattr(pipeline.run, "parallel_map", spy)
    out = run_config(_config(tmp_path, plots), workers=2, out_dir=tmp_path / "out",
                     progress=False)
    assert out.exit_code == 0 and len(started) == pools
    assert drawn == [plots != "none"]  # nothing to draw: the sections are built here
    assert (tmp_path / "out" / "report.md").is_file()
    assert (tmp_path / "out" / "plots").is_dir() == (plots != "none")  # only what it wrote
