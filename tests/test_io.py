"""Loaders: CSV (pandas index column, comments, units), .dat, sample time, bad files."""

import numpy as np
import pytest

from pipeline.errors import UserError
from pipeline.io import DataConfig, load_record


def _data(**kw):
    base = {"path": "x", "input": "u", "output": "y", "time": "time"}
    base.update(kw)
    return DataConfig(**base)


def test_csv_with_pandas_index_and_comments(tmp_path):
    p = tmp_path / "log.csv"
    p.write_text("# exported by the plant historian\n,time,u,y\n0,0.0,1.0,2.0\n1,0.5,1.0,2.1\n"
                 + "".join(f"{i},{i * 0.5},3.0,{2 + i * 0.1}\n" for i in range(2, 20)))
    rec = load_record(p, _data(units={"input": "V", "output": "degC"}))
    assert rec.n_samples == 20 and rec.sample_time == 0.5
    assert rec.u[0] == 1.0 and rec.y[1] == 2.1
    assert rec.units == {"input": "V", "output": "degC"}


def test_csv_sample_time_instead_of_time_column(tmp_path):
    p = tmp_path / "log.csv"
    p.write_text("u,y\n" + "".join(f"{1 + (i > 5)},{i}\n" for i in range(20)))
    rec = load_record(p, _data(time=None, sample_time=0.25))
    assert rec.t[-1] == pytest.approx(19 * 0.25)


def test_tclab_csv_from_the_mirror():
    from pipeline.io.datasets import fetch

    rec = load_record(fetch("tclab-kantor"), _data(input="Q1", output="T1", time="Time",
                                                  initial_input=0.0))
    assert rec.n_samples == 1001 and rec.sample_time is None  # jittered 0.99/1.00 s
    assert rec.u[0] == 50 and rec.initial_input == 0.0


def test_daisy_dat():
    from pipeline.io.datasets import fetch

    rec = load_record(fetch("daisy-heating"), _data(time="time", columns=["time", "u", "y"]))
    assert rec.n_samples == 801 and rec.sample_time == 2.0
    assert rec.y[0] == pytest.approx(129.32)


@pytest.mark.parametrize("content,expected", [
    ("time,u,y\n0,1,2\n" + "".join(f"{i},1,2\n" for i in range(1, 12)) + "12,1,oops\n",
     "line 14: column 'y' has 'oops'; expected a number"),
    ("time,u,yy\n" + "".join(f"{i},1,2\n" for i in range(12)), "no column 'y'"),
    ("", "empty"),
    ("time,u,y\n", "no data rows"),
    ("time,u,y\n" + "".join(f"{i},1,2\n" for i in range(12)) + "3,1,2\n",
     "time is not strictly increasing"),
    ("time,u,y\n" + "".join(f"{i},1,2\n" for i in range(12)) + "12,1,2,7\n13,1,2\n",
     "line 14: 4 fields where line 1 has 3; expected the same number of fields on every row"),
    ("time,u,y\n" + "".join(f"{i},1,2\n" for i in range(12)) + "12,1\n13,1,2\n",
     "line 14: column 'y' is empty (a drop-out)"),
])
def test_bad_csv_is_one_line(tmp_path, content, expected):
    p = tmp_path / "bad.csv"
    p.write_text(content)
    with pytest.raises(UserError) as exc:
        load_record(p, _data())
    assert expected in exc.value.message and str(p) in exc.value.message
    assert "\n" not in exc.value.message


def test_missing_file(tmp_path):
    with pytest.raises(UserError, match="file not found"):
        load_record(tmp_path / "nope.csv", _data())


def test_binary_garbage(tmp_path):
    p = tmp_path / "junk.csv"
    p.write_bytes(np.random.default_rng(0).bytes(3000))
    with pytest.raises(UserError) as exc:
        load_record(p, _data())
    assert str(p) in exc.value.message


@pytest.mark.parametrize("last,expected", [
    ("  100.0  9.000  abc\n", "line 51: column 'y' has 'abc'; expected a number"),
    ("  100.0  9.000\n", "line 51: '100.0 9.000' is not a data row after the data; expected "
     "3 fields of numbers, or set trailing_lines: skip"),
    ("  100.0  9.000\n" + "  102.0  9.000  150.0\n",
     "line 51: 2 fields where line 1 has 3; expected the same number of fields on every row"),
])
def test_bad_dat_names_the_file_line(tmp_path, last, expected):
    p = tmp_path / "bad.dat"
    p.write_text("".join(f"  {2.0 * i:.1f}  9.000  {129 + i:.3f}\n" for i in range(50)) + last)
    with pytest.raises(UserError) as exc:
        load_record(p, _data(time="time", columns=["time", "u", "y"]))
    assert expected in exc.value.message


def test_huge_time_gap_is_a_user_error(tmp_path):
    p = tmp_path / "gap.csv"
    p.write_text("time,u,y\n" + "".join(f"{i * 0.5},1,2\n" for i in range(20)) + "1e9,1,2\n")
    with pytest.raises(UserError, match="time jumps by"):
        load_record(p, _data())
