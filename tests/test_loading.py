"""Loading hardened and at polars speed (issue 13 items 1, 15, 16; issue 14 items 1, 6).

- file names are read literally (``run[1].csv`` is not ``run1.csv``);
- values that overflow squared errors are refused at load, ``inf`` is a drop-out as NaN;
- Unix-epoch stamps are a regular grid; a grid that is no sampling is refused;
- a plain delimited log is read directly (only its named columns) with exactly the result
  of the line-by-line reader, and the record holds polars' buffers read-only, uncopied.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import polars as pl
import pytest

import pipeline
from pipeline.analysis import AnalysisOptions, analyse
from pipeline.config import load_config
from pipeline.errors import UserError
from pipeline.io import format_of, load_record
from pipeline.io.delimited import read_text_table
from pipeline.io.options import DataConfig, options_for
from pipeline.io.plain import read_plain_table
from pipeline.io.table import table_to_record
from pipeline.run import resolve_specs
from tests.corpus import step_csv


def _config(folder: Path, path: str) -> Path:
    cfg = folder / "c.yaml"
    cfg.write_text(f"name: t\ndata:\n  path: '{path}'\n  input: u\n  output: y\n"
                   "  time: time\nmethods: [first_order]\n")
    return cfg


def _gain(path: Path, **data) -> float:
    record = pipeline.load(path, **{"input": "u", "output": "y", "time": "time", **data})
    res = analyse(record, AnalysisOptions(methods=("first_order",)))
    return res.recommended.model.params["K"]


# -- 13.1: literal file names ------------------------------------------------------------

@pytest.mark.parametrize("literal, other", [("run[1].csv", "run1.csv"),
                                            ("a*.csv", "ab.csv"), ("r?n.csv", "run.csv")])
def test_a_file_name_with_glob_characters_is_that_file(tmp_path, literal, other):
    (tmp_path / literal).write_text(step_csv(K=2.0))
    (tmp_path / other).write_text(step_csv(K=5.0, seed=1))
    specs = resolve_specs(load_config(_config(tmp_path, literal)))
    assert [Path(s.path).name for s in specs] == [literal]
    assert _gain(Path(specs[0].path)) == pytest.approx(2.0, rel=0.02)


def test_a_glob_still_chooses_files_inside_a_folder_with_brackets(tmp_path):
    folder = tmp_path / "plant[1]"
    folder.mkdir()
    for name in ("a.csv", "b.csv"):
        (folder / name).write_text(step_csv())
    (tmp_path / "plant1").mkdir()
    (tmp_path / "plant1" / "c.csv").write_text(step_csv())
    specs = resolve_specs(load_config(_config(folder, "*.csv")))
    assert sorted(Path(s.path).name for s in specs) == ["a.csv", "b.csv"]


@pytest.mark.parametrize("write", ["write_parquet", "write_ipc"])
def test_a_columnar_file_name_with_brackets_is_that_file(tmp_path, write):
    suffix = ".parquet" if write == "write_parquet" else ".arrow"
    t = np.arange(50.0)
    for name, y in ((f"run[1]{suffix}", t * 2), (f"run1{suffix}", t * 3)):
        getattr(pl.DataFrame({"t": t, "u": t, "y": y, "extra": t}), write)(tmp_path / name)
    rec = pipeline.load(tmp_path / f"run[1]{suffix}", input="u", output="y", time="t")
    np.testing.assert_array_equal(rec.y, t * 2)


# -- 13.15: values too large, infinite values --------------------------------------------

def _csv(tmp_path: Path, y: list[str], name: str = "log.csv") -> Path:
    p = tmp_path / name
    p.write_text("time,u,y\n" + "".join(f"{i},1,{v}\n" for i, v in enumerate(y)))
    return p


def test_values_that_overflow_squared_errors_are_refused_naming_file_and_column(tmp_path):
    p = _csv(tmp_path, ["1.0"] * 20 + ["1e308"] + ["1.0"] * 20)
    with pytest.raises(UserError, match=r"log\.csv: column 'y' has 1e\+308 .*scale the"):
        pipeline.load(p, input="u", output="y", time="time")
    assert pipeline.load(_csv(tmp_path, ["1e100"] * 40, "ok.csv"), input="u", output="y",
                         time="time").y[0] == 1e100


def test_inf_is_a_drop_out_as_nan_is(tmp_path):
    values = ["1.0"] * 20 + ["inf"] + ["3.0"] * 20
    with pytest.raises(UserError, match=r"line 22: column 'y' is inf \(a drop-out\).*fill_"):
        pipeline.load(_csv(tmp_path, values), input="u", output="y", time="time")
    rec = pipeline.load(_csv(tmp_path, values), input="u", output="y", time="time",
                        fill_gaps=1)
    assert rec.y[20] == pytest.approx(2.0)  # interpolated as a NaN would be
    nan = pipeline.load(_csv(tmp_path, [v.replace("inf", "nan") for v in values], "n.csv"),
                        input="u", output="y", time="time", fill_gaps=1)
    np.testing.assert_array_equal(rec.y, nan.y)


def test_an_infinite_time_stamp_is_one_line(tmp_path):
    p = tmp_path / "t.csv"
    p.write_text("time,u,y\n" + "".join(f"{i},1,2\n" for i in range(20)) + "inf,1,2\n")
    with pytest.raises(UserError, match=r"line 22: time column 'time' has inf"):
        pipeline.load(p, input="u", output="y", time="time")


# -- 13.16: the time base ----------------------------------------------------------------

def test_unix_epoch_stamps_at_10_hz_are_a_regular_grid_and_identify(tmp_path):
    text = step_csv(K=2.0, T=5.0, dt=0.1, n=2000, steps=((20.0, 1.0), (110.0, 0.0)))
    lines = text.splitlines()
    rows = [line.split(",") for line in lines[1:]]
    epoch = [f"{1.7e9 + 0.1 * i:.1f},{u},{y}" for i, (_, u, y) in enumerate(rows)]
    p = tmp_path / "epoch.csv"
    p.write_text("\n".join([lines[0], *epoch]) + "\n")
    raw = np.diff(np.array([float(r.split(",")[0]) for r in epoch]))
    assert np.ptp(raw) > 1e-6 * 0.1  # float64 jitter: irregular before making relative
    rec = pipeline.load(p, input="u", output="y", time="time")
    assert rec.sample_time == pytest.approx(0.1, rel=1e-9)
    assert rec.t[0] == 0.0 and any("epoch stamps" in n for n in rec.notes)
    fit = analyse(rec, AnalysisOptions(methods=("first_order",))).recommended.model.params
    assert fit["K"] == pytest.approx(2.0, rel=0.02)
    assert fit["T"] == pytest.approx(5.0, rel=0.05)


def test_a_bimodal_time_grid_loads_as_an_irregular_log(tmp_path):
    """The crafted 1 ms / 0.9 s grid is a log like any other: kept irregular (no sample
    time), simulated per distinct interval (tests/test_discretise.py), not refused."""
    steps = np.tile(np.r_[np.full(9, 0.001), 0.9], 1000)  # bursts of 1 ms, 0.9 s apart
    t = np.r_[0.0, np.cumsum(steps)]
    p = tmp_path / "bimodal.csv"
    pl.DataFrame({"time": t, "u": (t > 400).astype(float), "y": t * 0}).write_csv(p)
    rec = pipeline.load(p, input="u", output="y", time="time")
    assert rec.sample_time is None and rec.t.size == t.size
    np.testing.assert_allclose(rec.t, t - t[0])


def test_a_jittered_or_gappy_grid_is_still_accepted(tmp_path):
    rng = np.random.default_rng(0)
    t = np.cumsum(rng.uniform(0.05, 0.15, 3000))
    t[1500:] += 200.0  # one gap of 2000 steps is make_record's, not a bimodal grid
    p = tmp_path / "jitter.csv"
    pl.DataFrame({"time": t[:1500], "u": (t[:1500] > 50).astype(float), "y": t[:1500]}).write_csv(p)
    assert pipeline.load(p, input="u", output="y", time="time").sample_time is None


# -- 14.1 / 14.6: the direct read --------------------------------------------------------

PLAIN = {
    "plain.csv": step_csv(),
    "comments_first.csv": "# logger v2\n# 2024-01-01\n\n" + step_csv(),
    "crlf.csv": step_csv().replace("\n", "\r\n"),
    "bom.csv": "\ufeff" + step_csv(),
    "semicolon_comma.csv": step_csv(sep=";", header="time;u;y").replace(".", ","),
    "trailing_blank.csv": step_csv() + "\n\n",
    "no_header.csv": step_csv().split("\n", 1)[1],
    "extra_columns.csv": "id,time,u,note,y\n" + "".join(
        f"{i},{line.replace(',', ',x,', 2).replace(',x,', ',', 1)}\n"
        for i, line in enumerate(step_csv().splitlines()[1:])),
    "datetime.csv": "time,u,y\n" + "".join(
        f"2024-05-01T10:{i // 60:02d}:{i % 60:02d}+02:00,{1.0 * (i > 30)},{i * 0.5}\n"
        for i in range(120)),
}
NOT_PLAIN = {
    "blank_in_middle.csv": step_csv().replace("\n10,", "\n\n10,", 1),
    "comment_in_middle.csv": step_csv().replace("\n150,", "\n# paused\n150,", 1),
    "spaces.csv": step_csv().replace(",", ", "),
    "footer.csv": step_csv() + "End of log\n",
    "dropout.csv": step_csv().replace("\n100,1,", "\n100,,", 1),
}


def _both(path: Path, **keys):
    data = DataConfig(path=str(path), input="u", output="y", **keys)
    options = options_for(data, format_of(path), str(path))
    slow = table_to_record(read_text_table(path, options), data, options, path.stem)
    direct = read_plain_table(path, data, options, delimiter=options.delimiter,
                              decimal=options.decimal, header=options.header,
                              columns=options.columns)
    return slow, direct, load_record(path, data)


def _same(a, b):
    for k in ("t", "u", "y"):
        np.testing.assert_array_equal(getattr(a, k), getattr(b, k))
    assert (a.sample_time, a.notes, a.units, a.start) == (b.sample_time, b.notes, b.units,
                                                          b.start)


@pytest.mark.parametrize("name", PLAIN)
def test_a_plain_log_is_read_directly_with_the_line_by_line_result(tmp_path, name):
    p = tmp_path / name
    p.write_bytes(PLAIN[name].encode())
    keys = ({"columns": ["time", "u", "y"]} if name == "no_header.csv" else {})
    slow, direct, record = _both(p, time="time", **keys)
    assert direct is not None
    assert set(direct.positions) <= {0, *[direct.names.index(c) for c in ("time", "u", "y")]}
    _same(slow, record)
    assert not record.y.flags.writeable and not record.t.flags.writeable


@pytest.mark.parametrize("name", NOT_PLAIN)
def test_a_log_that_is_not_plain_goes_line_by_line(tmp_path, name):
    p = tmp_path / name
    p.write_text(NOT_PLAIN[name])
    keys = {"fill_gaps": 1} if name == "dropout.csv" else {}
    keys |= {"trailing_lines": "skip"} if name == "footer.csv" else {}
    slow, direct, record = _both(p, time="time", **keys)
    assert direct is None
    _same(slow, record)


def test_columns_named_by_position_and_a_sample_time(tmp_path):
    p = tmp_path / "pos.csv"
    p.write_text(PLAIN["extra_columns.csv"])
    data = DataConfig(path=str(p), input=2, output=4, sample_time=0.5)
    record = load_record(p, data)
    ref = pl.read_csv(p)
    np.testing.assert_array_equal(record.y, ref["y"].to_numpy())
    assert record.sample_time == 0.5


def test_the_record_holds_polars_buffers_read_only_without_a_copy(tmp_path):
    p = tmp_path / "big.csv"
    n = 200_000
    t = np.arange(n) * 0.01
    pl.DataFrame({"t": t, "u": (t > 100).astype(float), "y": np.sin(t)}).write_csv(p)
    rec = pipeline.load(p, input="u", output="y", time="t")
    for a in (rec.t, rec.u, rec.y):
        assert not a.flags.writeable and not a.flags.owndata  # a view of polars' buffer
        with pytest.raises(ValueError):
            a[0] = 1.0
    np.testing.assert_allclose(rec.y, np.sin(t), rtol=1e-15, atol=1e-15)
