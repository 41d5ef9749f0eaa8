"""The quirks of real logs: detection of the text layout, columns and units from headers,
the time base (units, date-times, zones, DST) and the policies, each with its note."""

from __future__ import annotations

import numpy as np
import pytest

from pipeline.errors import UserError
from pipeline.io import DataConfig, load_record
from pipeline.record import in_time_unit


def _load(path, **keys):
    base = {"input": "u", "output": "y", "time": "time"}
    return load_record(path, DataConfig(path=str(path), **{**base, **keys}))


def _write(tmp_path, text: str, name: str = "log.csv"):
    p = tmp_path / name
    p.write_text(text, encoding="utf-8")
    return p


def _rows(n: int = 20, fmt: str = "{t},{u},{y}", t=lambda i: i * 0.5) -> str:
    return "".join(fmt.format(t=t(i), u=1.0 + (i > 5), y=2.0 + 0.1 * i) + "\n"
                   for i in range(n))


@pytest.mark.parametrize("text,keys", [
    ("time,u,y\n" + _rows(), {}),
    ("time;u;y\n" + _rows(fmt="{t};{u};{y}").replace(".", ","), {}),
    ("time\tu\ty\n" + _rows(fmt="{t}\t{u}\t{y}"), {}),
    ("time u y\n" + _rows(fmt="{t}   {u}  {y}"), {}),
    (_rows(fmt="{t} {u} {y}").replace(".", ","), {"time": 0, "input": 1, "output": 2}),
    (_rows(), {"time": "0", "input": "1", "output": "2"}),
    ("# exported\n\ntime;u;y\n" + _rows(fmt="{t};{u};{y}"), {}),
])
def test_layouts_are_detected(tmp_path, text, keys):
    rec = _load(_write(tmp_path, text), **keys)
    assert rec.n_samples == 20 and rec.t[3] == 1.5 and rec.y[4] == pytest.approx(2.4)
    assert rec.u[0] == 1.0 and rec.u[-1] == 2.0


def test_options_override_detection(tmp_path):
    p = _write(tmp_path, _rows(fmt="{t};{u};{y}"))
    rec = _load(p, delimiter=";", decimal=".", header=False, columns=["time", "u", "y"])
    assert rec.n_samples == 20


def test_header_names_trimmed_and_units_taken(tmp_path):
    p = _write(tmp_path, "Time (s), Heater 1 (%), Temperature 1 [degC]\n" + _rows())
    for ref in ("Heater 1 (%)", " Heater 1 (%) ", "Heater 1"):
        rec = _load(p, time="Time", input=ref, output="Temperature 1")
        assert rec.units == {"time": "s", "input": "%", "output": "degC"}
        assert rec.input_name == "Heater 1"
        assert rec.notes == ("units from the header: time s, input %, output degC",)
    rec = _load(p, time=0, input=1, output=2, units={"output": "K"})
    assert rec.units["output"] == "K" and rec.notes == ("units from the header: time s, "
                                                        "input %",)


def test_time_units_convert_and_stay_the_display_unit(tmp_path):
    p = _write(tmp_path, "time,u,y\n" + _rows(t=lambda i: i * 500))
    for keys in ({"time_unit": "ms"}, {"units": {"time": "ms"}}, {"time_unit": "msec"}):
        rec = _load(p, **keys)
        assert rec.t[3] == 1.5 and rec.units["time"] == "ms"
    assert in_time_unit(450.0, "min") == 7.5 and in_time_unit(0.25, "ms") == 250.0
    with pytest.raises(UserError, match="units.time 's' and time_unit 'ms' disagree"):
        _load(p, time_unit="ms", units={"time": "s"})
    rec = _load(p, time=None, sample_time=250, time_unit="ms")
    assert rec.t[2] == 0.5


def test_datetimes_zones_and_start(tmp_path):
    stamps = [f"2024-03-31 01:59:{55 + i // 2:02d}.{5 * (i % 2)}" for i in range(20)]
    stamps = stamps[:10] + [f"2024-03-31 03:00:{i // 2:02d}.{5 * (i % 2)}" for i in range(10)]
    p = _write(tmp_path, "time,u,y\n" + "".join(
        f"{s},{1.0 + (i > 5)},{i}\n" for i, s in enumerate(stamps)))
    rec = _load(p, time_zone="Europe/Berlin")  # spring: 02:00 CET is 03:00 CEST
    assert np.allclose(np.diff(rec.t), 0.5) and rec.start == "2024-03-31T01:59:55+01:00"
    with pytest.raises(UserError, match=r"line 12: time jumps|time is not|jumps"):
        _load(p)  # as UTC the clock jumps an hour
    gap = stamps[:10] + ["2024-03-31 02:30:00"] + stamps[11:]
    p = _write(tmp_path, "time,u,y\n" + "".join(f"{s},1,{i}\n" for i, s in enumerate(gap)))
    with pytest.raises(UserError) as exc:
        _load(p, time_zone="Europe/Berlin")
    assert "line 12: time column 'time' has 2024-03-31 02:30:00, which does not exist in " \
           "Europe/Berlin" in exc.value.message


def test_naive_datetimes_without_zone_are_utc_with_a_note(tmp_path):
    p = _write(tmp_path, "time,u,y\n" + _rows(t=lambda i: f"2024-01-05T10:00:{i:02d}"))
    rec = _load(p)
    assert rec.t[-1] == 19.0 and rec.start == "2024-01-05T10:00:00+00:00"
    assert "taken as UTC" in rec.notes[0]


@pytest.mark.parametrize("policy,y1", [("mean", 2.15), ("first", 2.1)])
def test_repeated_stamps(tmp_path, policy, y1):
    body = "".join(f"{i // 2 * 0.5},1,{2 + 0.1 * i}\n" for i in range(40))
    p = _write(tmp_path, "time,u,y\n" + body)
    with pytest.raises(UserError) as exc:
        _load(p)
    assert exc.value.message.endswith("line 3: the time stamp 0 s repeats; expected increasing "
                                      "time stamps, or set duplicates: mean (or first) to "
                                      "merge the rows of a stamp")
    rec = _load(p, duplicates=policy)
    assert rec.n_samples == 20 and rec.y[0] == pytest.approx(y1 - 0.1)
    assert rec.notes[0].startswith("duplicates: 20 time stamps repeat on 40 rows (the first "
                                   "at line 2)")


def test_dropouts(tmp_path):
    rows = [[i * 0.5, 1.0 + (i > 9), 2.0 + i] for i in range(40)]
    rows[4][2] = rows[12][1] = ""          # two single drop-outs
    rows[20][2] = rows[21][2] = rows[22][2] = ""  # one of three rows
    p = _write(tmp_path, "time,u,y\n" + "".join(",".join(map(str, r)) + "\n" for r in rows))
    with pytest.raises(UserError) as exc:
        _load(p)
    assert exc.value.message.endswith("line 6: column 'y' is empty (a drop-out); expected a "
                                      "number, or set fill_gaps: N to fill drop-outs of up to "
                                      "N rows")
    rec = _load(p, fill_gaps=3)
    assert rec.n_samples == 40 and rec.y[4] == 6.0 and rec.u[12] == 2.0 and rec.y[21] == 23.0
    assert rec.notes == ("fill_gaps: 3 drop-out(s) of up to 3 rows filled (input held, output "
                         "interpolated), the first at line 6",)
    with pytest.raises(UserError, match="line 22: 3 rows without a value .* or set long_gaps"):
        _load(p, fill_gaps=1)
    rec = _load(p, fill_gaps=1, long_gaps="keep_longest")
    assert rec.n_samples == 20 and rec.t[0] == 0.0 and rec.y[4] == 6.0
    assert rec.notes == ("long_gaps: 1 drop-out(s) longer than 1 rows; line 2 to line 21 (the "
                         "longest stretch without one, 20 rows) are kept",
                         "fill_gaps: 2 drop-out(s) of up to 1 rows filled (input held, output "
                         "interpolated), the first at line 6")


def test_trailing_lines(tmp_path):
    p = _write(tmp_path, "time,u,y\n" + _rows() + "End of log\nTotal rows: 20\n")
    with pytest.raises(UserError) as exc:
        _load(p)
    assert exc.value.message.endswith("line 22: 'End of log' is not a data row after the "
                                      "data; expected 3 fields of numbers, or set "
                                      "trailing_lines: skip")
    rec = _load(p, trailing_lines="skip")
    assert rec.n_samples == 20
    assert rec.notes == ("trailing_lines: 2 line(s) after the data skipped, from line 22 "
                         "('End of log')",)


@pytest.mark.parametrize("text,keys,expected", [
    ("time,1,2\n" + _rows(), {}, "line 1 mixes names and numbers ('time', '1', '2'): cannot "
     "tell whether it is a header"),
    ("t,u,u\n" + _rows(), {"time": "t"}, "input 'u': 2 columns have that name (positions 1, "
     "2); name one by position"),
    ("time,u,y\n" + _rows(), {"input": 5}, "input 5: no column at position 5; the columns are "
     "0..2 ('time', 'u', 'y')"),
    ("time,u,y\n" + _rows(t=lambda i: f"2024-01-05 10:00:{i:02d}"), {"time_format": "%d.%m.%Y"},
     "line 2: time column 'time' has '2024-01-05 10:00:00'; expected date-times like "
     "'%d.%m.%Y' (time_format)"),
    ("time,u,y\n" + _rows(t=lambda i: "yesterday" if i == 3 else f"2024-01-05 10:00:{i:02d}"),
     {}, "line 5: time column 'time' has 'yesterday'; expected a number or an ISO-8601 "
     "date-time"),
    ("time,u,y\n" + _rows(t=lambda i: "x" if i == 3 else i), {}, "line 5: time column 'time' "
     "has 'x'; expected a number like the rows before"),
    ("values\n1\n2\n3\n", {}, "cannot tell how the fields are separated"),
    # a short table with a ragged row: the row is named, not the delimiter blamed
    ("time,u,y\n0,1,2\n1,1,3\n2,1\n", {}, "line 4 has 2 fields where the first line has "
     "3 (comma-separated); expected 3 fields on every line"),
])
def test_bad_layouts_are_one_line(tmp_path, text, keys, expected):
    p = _write(tmp_path, text)
    with pytest.raises(UserError) as exc:
        _load(p, **keys)
    assert str(p) in exc.value.message and expected in exc.value.message


def test_time_format_reads_other_layouts(tmp_path):
    p = _write(tmp_path, "Zeit;u;y\n" + "".join(
        f"27.10.2024 02:59:{50 + i // 2:02d},{5 * (i % 2)};{1 + (i > 5)},0;{2 + i},5\n"
        for i in range(20)))
    rec = _load(p, time="Zeit", time_format="%d.%m.%Y %H:%M:%S%.f", time_zone="Europe/Berlin")
    assert rec.t[-1] == 9.5 and rec.start == "2024-10-27T02:59:50+02:00"
    assert rec.y[0] == 2.5 and rec.u[-1] == 2.0


def test_typed_date_times_of_a_workbook_and_a_parquet_file(tmp_path):
    import datetime as dt

    import polars as pl

    stamps = [dt.datetime(2024, 10, 27, 9, 59, 55) + dt.timedelta(seconds=0.5 * i)
              for i in range(20)]
    frame = pl.DataFrame({"when": stamps, "u": [1.0 + (i > 5) for i in range(20)],
                          "y": [2.0 + i for i in range(20)]})
    frame.write_excel(tmp_path / "log.xlsx")
    rec = _load(tmp_path / "log.xlsx", time="when", time_zone="Europe/Berlin")
    assert rec.t[-1] == 9.5 and rec.start == "2024-10-27T09:59:55+01:00"
    aware = frame.with_columns(pl.col("when").dt.replace_time_zone("Europe/Berlin"))
    aware.write_parquet(tmp_path / "log.parquet")
    rec = _load(tmp_path / "log.parquet", time="when")
    assert rec.t[-1] == 9.5 and rec.start == "2024-10-27T09:59:55+01:00"


def test_mat_structs_and_matrix_columns(tmp_path):
    import scipy.io

    t = np.arange(20) * 0.5
    data = np.column_stack([t, 1.0 + (t > 3), 2.0 + t])
    scipy.io.savemat(tmp_path / "m.mat", {"Ts": 0.5, "data": data,
                                          "log": {"u": data[:, 1], "y": data[:, 2]}})
    rec = _load(tmp_path / "m.mat", time="data[0]", input="log.u", output="data[2]")
    assert rec.n_samples == 20 and rec.u[-1] == 2.0 and rec.y[3] == 3.5
    rec = _load(tmp_path / "m.mat", time=0, input=3, output=4)  # the file's order
    assert rec.input_name == "log.u" and rec.output_name == "log.y"


@pytest.mark.parametrize("name,sep", [("log.txt", ","), ("log.txt", " "), ("log.tsv", "\t")])
def test_txt_and_tsv_go_through_the_same_reader(tmp_path, name, sep):
    p = _write(tmp_path, sep.join(["Time", "u", "y"]) + "\n" + _rows(fmt=sep.join(
        ["{t}", "{u}", "{y}"])), name)
    rec = _load(p, time="Time")
    assert rec.n_samples == 20 and rec.t[1] == 0.5


def test_a_wrapping_counter_is_unwrapped_and_identified(tmp_path):
    """A shaft-angle counter that wraps every 230.4 counts (the DC-motor log's): unwrapped,
    it is the integrator with lag it measures (K within 2 %, T within 5 %)."""
    from pipeline.analysis import AnalysisOptions, analyse
    from pipeline.models import ProcessModel
    from pipeline.synth import response, staircase

    plant = ProcessModel("integrator_lag", {"K": 18.0, "T": 0.1, "delay": 0.0})
    t = np.arange(0.0, 8.0, 0.01)
    u = staircase(t, 5.0, [(2.0, 15.0)])
    angle = response(plant, t, u, 5.0, 40.0, 0.05, 3)  # at rest at u = 5 V: balanced
    counter = np.mod(angle, 230.4)
    path = _write(tmp_path, "time,u,y\n" + "".join(
        f"{a},{b},{c}\n" for a, b, c in zip(t, u, counter, strict=True)))
    rec = _load(path, unwrap=230.4)
    assert np.max(np.abs(rec.y - angle)) < 1e-9
    assert any(n.startswith("unwrap: output 'y' unwrapped with period 230.4") for n in rec.notes)
    fit = analyse(rec, AnalysisOptions(methods=("lsq_integrator_lag",))).fit(
        "lsq_integrator_lag", 0)
    assert abs(fit.model.K / 18.0 - 1) < 0.02 and abs(fit.model.params["T"] / 0.1 - 1) < 0.05
    wrapped = _load(path)  # without the option the counter's sawtooth stays
    assert np.max(wrapped.y) < 230.4
