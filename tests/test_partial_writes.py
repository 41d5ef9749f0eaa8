"""A history or JUnit write that fails after the report was published (a full disk;
issue 31) says exactly what the run wrote and what it did not."""

from __future__ import annotations

import pytest

from pipeline.errors import UserError
from pipeline.run import run_config
from pipeline.synth.logs import write_synthetic_logs


@pytest.fixture()
def night(tmp_path):
    write_synthetic_logs(tmp_path / "logs", 2, seed=2, n_steps=2)
    cfg = tmp_path / "night.yaml"
    cfg.write_text("name: night\ndata: {path: logs, input: u, output: y, time: time}\n"
                   "methods: [first_order]\nreport: {plots: none}\n")
    return tmp_path, cfg


def full_disk(what):
    def write(path, *a, **k):
        raise UserError(f"{path}: cannot write the {what} (No space left on device)")
    return write


@pytest.mark.parametrize("fails", ["history", "junit"])
def test_a_failed_history_or_junit_says_what_was_written(night, monkeypatch, fails):
    import pipeline.gate.history as history_module
    import pipeline.report.junit as junit_module

    d, cfg = night
    kw = {"out_dir": d / "out", "history": d / "h.parquet", "junit": d / "j.xml",
          "progress": False, "workers": 1}
    assert run_config(cfg, **kw).exit_code == 0  # the twin: all three written
    module = history_module if fails == "history" else junit_module
    monkeypatch.setattr(module, "write_atomic", full_disk(fails))
    with pytest.raises(UserError) as raised:
        run_config(cfg, **kw)
    msg = raised.value.message
    assert "No space left on device" in msg
    assert f"written: the reports in {d / 'out'}" in msg
    if fails == "history":
        assert msg.endswith(f"not written: the history row in {d / 'h.parquet'}, the JUnit "
                            f"file {d / 'j.xml'}")
    else:
        assert f"the history row in {d / 'h.parquet'}; not written: the JUnit file" in msg
    assert (d / "out" / "results.json").exists()
