"""Files as users have them (issue 29): a ``.dat`` table wider than DaISy's three columns
loads by position, and a text log with a banner before its table loads (``skip_rows`` /
``--skip-rows``, or the banner found and skipped with a note). The model read from each
is the plant's (K = 2, T = 10 s)."""

from __future__ import annotations

import numpy as np
import pytest
from typer.testing import CliRunner

import pipeline
from pipeline.cli.commands import app
from pipeline.errors import UserError

runner = CliRunner()


def _signals():
    t = np.arange(0.0, 200.0, 1.0)
    u = np.where(t >= 20.0, 1.0, 0.0)
    y = 4.0 + 2.0 * (1.0 - np.exp(-np.clip(t - 20.0, 0.0, None) / 10.0))
    y = y + np.random.default_rng(0).normal(0.0, 0.005, t.size)
    return t, u, y


def _gain_and_lag(rec):
    model = pipeline.analyse(rec).recommended.model
    return model.K, model.time_scale


def test_a_five_column_dat_file_loads_by_position(tmp_path):
    t, u, y = _signals()
    p = tmp_path / "five.dat"
    np.savetxt(p, np.c_[t, u, 0.5 * u, y, 2.0 * y], fmt="%.6f")
    rec = pipeline.load(p, time=0, input=1, output=3)
    k, lag = _gain_and_lag(rec)
    assert k == pytest.approx(2.0, rel=0.01) and lag == pytest.approx(10.0, rel=0.03)
    with pytest.raises(UserError, match="no column 'u'"):
        pipeline.load(p, time=0, input="u", output="y")  # no DaISy names beyond 3 columns


def _banner_csv(tmp_path, banner: str):
    t, u, y = _signals()
    p = tmp_path / "banner.csv"
    p.write_text(banner + "time,u,y\n" + "".join(f"{a:g},{b:g},{c:.6f}\n"
                                                 for a, b, c in zip(t, u, y, strict=True)))
    return p


BANNER = "Logged by TCLab 1.0 on 2026-12-06\nOperator: A. User; plate 3\n\n"


def test_a_banner_is_found_and_skipped_with_a_note(tmp_path):
    p = _banner_csv(tmp_path, BANNER)
    rec = pipeline.load(p, time="time", input="u", output="y")
    assert rec.n_samples == 200
    assert any("skipped 2 line(s) before the table" in n and "skip_rows: 2" in n
               for n in rec.notes)
    k, lag = _gain_and_lag(rec)
    assert k == pytest.approx(2.0, rel=0.01) and lag == pytest.approx(10.0, rel=0.03)


def test_skip_rows_says_it_and_the_note_goes(tmp_path):
    p = _banner_csv(tmp_path, BANNER)
    rec = pipeline.load(p, time="time", input="u", output="y", skip_rows=3)
    assert rec.n_samples == 200 and not any("skipped" in n for n in rec.notes)
    r = runner.invoke(app, ["identify", str(p), "--time", "time", "--input", "u", "--output",
                            "y", "--skip-rows", "2", "-q"])
    assert r.exit_code == 0, r.output
    assert "Recommended model for banner" in r.stdout
    cfg = tmp_path / "c.yaml"
    cfg.write_text(f"name: b\ndata:\n  path: {p}\n  time: time\n  input: u\n  output: y\n"
                   "  skip_rows: 2\n")
    r = runner.invoke(app, ["run", str(cfg), "--check"])
    assert r.exit_code == 0 and "ok, 200 samples" in r.stdout, r.output


def test_prose_is_still_no_table(tmp_path):
    p = tmp_path / "notes.txt"
    p.write_text("".join(f"line {i} of a letter, not a log; really.\n" if i % 2 else
                         f"another sentence {i}\n" for i in range(40)))
    with pytest.raises(UserError, match="cannot tell how the fields are separated"):
        pipeline.load(p, time=0, input=1, output=2)


def test_a_header_of_another_width_is_no_banner(tmp_path):
    """Review: ``time,u,y,`` (a trailing comma) was skipped as a banner and the columns
    named by position; it is a header of another width, and the error says so."""
    p = tmp_path / "trailing.csv"
    p.write_text("time,u,y,\n" + "".join(f"{i},1,2\n" for i in range(30)))
    with pytest.raises(UserError, match="cannot tell how the fields are separated"):
        pipeline.load(p, time="time", input="u", output="y")
