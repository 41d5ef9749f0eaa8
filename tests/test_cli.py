"""The command line: exit codes, one-line errors without traceback, nothing half-written."""

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from pipeline.cli.commands import app
from pipeline.models import ProcessModel
from pipeline.synth import step_record
from tests.conftest import have_mirror

runner = CliRunner()
ROOT = Path(__file__).resolve().parent.parent


def _csv(tmp_path, name="log.csv", **kw) -> Path:
    rec = step_record(ProcessModel("first_order", {"K": 2.5, "T": 7.0}), u0=1.5,
                      changes=[(13.7, 3.5), (113.7, 2.0)], t_end=213.7, dt=0.1, y0=-4.0,
                      noise=0.02, **kw)
    p = tmp_path / name
    rows = zip(rec.t, rec.u, rec.y, strict=True)
    lines = ["time,u,y"] + [f"{a:.4f},{b:.6f},{c:.6f}" for a, b, c in rows]
    p.write_text("\n".join(lines) + "\n")
    return p


def _one_line_error(result, *needles):
    assert result.exit_code == 2, result.output
    err = result.stderr.strip()
    assert len(err.splitlines()) == 1, err
    assert "Traceback" not in result.output and "Traceback" not in err
    for n in needles:
        assert n in err


def test_identify_json_is_the_results_object(tmp_path):
    p = _csv(tmp_path)
    r = runner.invoke(app, ["identify", str(p), "--input", "u", "--output", "y", "--time",
                            "time", "--method", "first_order", "--json"])
    assert r.exit_code == 0, r.output
    doc = json.loads(r.stdout)
    (rec,) = doc["records"]
    assert [e["role"] for e in rec["events"]] == ["identification", "validation"]
    (fit,) = rec["fits"]
    assert fit["params"]["K"] == pytest.approx(2.5, rel=0.02)
    assert fit["params"]["T"] == pytest.approx(7.0, rel=0.02)
    assert fit["transfer_function"]["den"][1] == 1.0
    assert fit["metrics"]["mse_validation"] == pytest.approx(0.02**2, rel=0.3)


def test_identify_table_and_reports(tmp_path):
    p = _csv(tmp_path)
    out = tmp_path / "rep"
    r = runner.invoke(app, ["identify", str(p), "--input", "u", "--output", "y",
                            "--time", "time", "--method", "all", "--out", str(out)])
    assert r.exit_code == 0, r.output
    assert "first_order" in r.stdout
    assert {"report.html", "report.md", "results.json"} <= {f.name for f in out.iterdir()}
    html = (out / "report.html").read_text()
    assert "data:image/png;base64," in html and "<img" in html


def test_segment_json(tmp_path):
    p = _csv(tmp_path)
    r = runner.invoke(app, ["segment", str(p), "--input", "u", "--output", "y", "--time",
                            "time", "--json"])
    assert r.exit_code == 0
    evs = json.loads(r.stdout)
    assert [round(e["t0"], 1) for e in evs] == [13.7, 113.7]
    assert [e["kind"] for e in evs] == ["step", "step"]


def test_methods_lists_the_catalogue():
    r = runner.invoke(app, ["methods"])
    assert r.exit_code == 0
    for mid in ("first_order", "second_order_overshoot"):
        assert mid in r.stdout


@pytest.mark.parametrize("args,needles", [
    (["identify", "missing.csv", "--input", "u", "--output", "y", "--time", "time"],
     ["missing.csv", "file not found"]),
    (["identify", "{csv}", "--input", "power", "--output", "y", "--time", "time"],
     ["no column 'power'"]),
    (["identify", "{csv}", "--input", "u", "--output", "y"], ["--time"]),
    (["identify", "{csv}", "--input", "u", "--output", "y", "--time", "time", "--method",
      "nope"], ["'nope'"]),
    (["run", "missing.yaml"], ["missing.yaml", "not found"]),
])
def test_user_errors_are_one_line_exit_2(tmp_path, args, needles):
    p = _csv(tmp_path)
    args = [a.replace("{csv}", str(p)) for a in args]
    _one_line_error(runner.invoke(app, args), *needles)


def _config(tmp_path, body: str) -> Path:
    c = tmp_path / "cfg.yaml"
    c.write_text(body)
    return c


def test_run_config_typo_leaves_no_output(tmp_path):
    p = _csv(tmp_path)
    c = _config(tmp_path, f"name: t\ndata:\n  path: {p.name}\n  input: u\n  outptu: y\n")
    out = tmp_path / "out"
    _one_line_error(runner.invoke(app, ["run", str(c), "--out", str(out)]),
                    "unknown key 'data.outptu'")
    assert not out.exists()


def test_run_missing_column_is_one_line_and_a_report(tmp_path):
    p = _csv(tmp_path)
    c = _config(tmp_path, f"name: t\ndata:\n  path: {p.name}\n  input: u\n  output: temp\n"
                "  time: time\n")
    out = tmp_path / "out"
    _one_line_error(runner.invoke(app, ["run", str(c), "--out", str(out), "--workers", "1"]),
                    "no column 'temp'")
    # the only record failed: exit 2, and the report says why (issue 13 item 12)
    doc = json.loads((out / "results.json").read_text())
    assert [r["status"] for r in doc["records"]] == ["failed"]
    assert "no column" in (out / "report.html").read_text()
    assert not [f for f in out.iterdir() if ".tmp-" in f.name]


def test_run_missing_data_file_leaves_no_output(tmp_path):
    c = _config(tmp_path, "name: t\ndata:\n  path: nope.csv\n  input: u\n  output: y\n"
                "  time: time\n")
    out = tmp_path / "out"
    _one_line_error(runner.invoke(app, ["run", str(c), "--out", str(out)]), "nope.csv")
    assert not out.exists()


def test_run_writes_all_reports(tmp_path):
    p = _csv(tmp_path)
    c = _config(tmp_path, f"name: t\ndata:\n  path: {p.name}\n  input: u\n  output: y\n"
                "  time: time\n  units: {time: s, input: V, output: degC}\n")
    out = tmp_path / "out"
    r = runner.invoke(app, ["run", str(c), "--out", str(out), "--workers", "1"])
    assert r.exit_code == 0, r.output
    doc = json.loads((out / "results.json").read_text())
    record = doc["records"][0]
    assert record["recommended"] is not None and record["best"] is None  # one answer
    assert (out / "report.md").read_text().count("![") >= 3
    assert all((out / "plots").iterdir())


def test_subprocess_has_no_traceback(tmp_path):
    """The installed entry point, as a user runs it."""
    c = _config(tmp_path, "name: t\ndata:\n  path: x.csv\n  input: u\n  output: y\n  bogus: 1\n")
    r = subprocess.run([sys.executable, "-m", "pipeline", "run", str(c)], capture_output=True,
                       text=True)
    assert r.returncode == 2
    assert r.stderr.strip().count("\n") == 0 and "Traceback" not in r.stderr
    assert "unknown key 'data.bogus'" in r.stderr


@pytest.mark.skipif(not have_mirror(), reason="needs the DaISy mirror")
def test_thermal_flagship(tmp_path):
    """Issue 2's headline: DaISy, first step for identification, five for validation."""
    out = tmp_path / "thermal"
    r = runner.invoke(app, ["run", str(ROOT / "configs" / "thermal.yaml"), "--out", str(out),
                            "--workers", "1"])
    assert r.exit_code == 0, r.output
    doc = json.loads((out / "results.json").read_text())
    (rec,) = doc["records"]
    assert [e["role"] for e in rec["events"]] == ["identification"] + ["validation"] * 5
    fo = next(f for f in rec["fits"] if f["method"] == "first_order")
    assert 19 <= fo["params"]["K"] <= 23
    assert 50 <= fo["params"]["T"] <= 70
    assert 0 < fo["metrics"]["mse_validation"] < 80
    assert np.isfinite(fo["metrics"]["fit_percent"])
    # one record: its answer's head on stdout, as identify prints it (issue 29)
    lines = r.stdout.splitlines()
    rec_fit = rec["recommended"]
    assert lines[0] == f"Recommended model for daisy-heating: {rec_fit['verdict']}"
    assert lines[1].startswith("  G(s) = ") and f"({rec_fit['method']}, event 0;" in lines[1]
    assert any(ln.startswith("Controller: PI by SIMC") for ln in lines)
    assert lines[-1].startswith("1 of 1 record(s) identified")


def test_out_keeps_files_it_did_not_write(tmp_path):
    p = _csv(tmp_path)
    out = tmp_path / "userdir"
    out.mkdir()
    (out / "notes.txt").write_text("important")
    args = ["identify", str(p), "--input", "u", "--output", "y", "--time", "time",
            "--method", "first_order", "--out", str(out)]
    assert runner.invoke(app, args).exit_code == 0
    assert runner.invoke(app, args).exit_code == 0  # replaces its own outputs
    assert (out / "notes.txt").read_text() == "important"
    assert (out / "report.html").is_file()
    assert not [f for f in tmp_path.iterdir() if f.name.startswith(".userdir")]


def test_out_dot(tmp_path, monkeypatch):
    p = _csv(tmp_path)
    work = tmp_path / "work"
    work.mkdir()
    monkeypatch.chdir(work)
    r = runner.invoke(app, ["identify", str(p), "--input", "u", "--output", "y", "--time",
                            "time", "--method", "first_order", "--out", "."])
    assert r.exit_code == 0, r.output
    assert (work / "results.json").is_file()


@pytest.mark.parametrize("extra,needle", [
    (["--sample-time", "0"], "--sample-time"),
    (["--sample-time", "nan"], "--sample-time"),
    (["--time", "time", "--events", "-1"], "--events"),
    (["--time", "time", "--events", ","], "--events"),
    (["--time", "time", "--initial-input", "nan"], "initial_input"),
    (["--time", "time", "--method", "all", "--method", "foo"], "'foo'"),
])
def test_bad_options_are_one_line(tmp_path, extra, needle):
    p = _csv(tmp_path)
    _one_line_error(runner.invoke(app, ["identify", str(p), "--input", "u", "--output", "y",
                                        *extra]), needle)


def test_history_inside_the_output_folder_survives(tmp_path):
    p = _csv(tmp_path)
    c = _config(tmp_path, f"name: t\ndata:\n  path: {p.name}\n  input: u\n  output: y\n"
                "  time: time\nmethods: [first_order]\n")
    out = tmp_path / "out"
    for _ in range(2):
        r = runner.invoke(app, ["run", str(c), "--out", str(out), "--workers", "1",
                                "--history", str(out / "history.parquet")])
        assert r.exit_code == 0, r.output
    import polars as pl

    assert pl.read_parquet(out / "history.parquet")["time"].n_unique() == 2


def test_colliding_record_names_are_made_unique(tmp_path):
    for d in ("p1/x", "p2/x"):
        (tmp_path / d).mkdir(parents=True)
        _csv(tmp_path / d, name="r.csv")
    c = _config(tmp_path, "name: t\ndata:\n  paths: [p1/x/r.csv, p2/x/r.csv, p1/x/r.csv]\n"
                "  input: u\n  output: y\n  time: time\nmethods: [first_order]\n")
    out = tmp_path / "out"
    r = runner.invoke(app, ["run", str(c), "--out", str(out), "--workers", "1"])
    assert r.exit_code == 0, r.output
    names = [rec["name"] for rec in json.loads((out / "results.json").read_text())["records"]]
    assert len(set(names)) == 3, names
    assert names == ["p1/x/r", "p2/x/r", "p1/x/r#2"]
    assert len(list((out / "plots").glob("*e0_ranking.png"))) == 3  # nothing overwritten


def test_synth_with_too_many_corrupt_logs_is_one_line(tmp_path):
    _one_line_error(runner.invoke(app, ["datasets", "synth", str(tmp_path / "x"), "--n", "2",
                                        "--corrupt", "5"]), "corrupt must be between 0 and n=2")
    assert not (tmp_path / "x").exists()


@pytest.mark.parametrize("extra,needle", [
    (["--tol", "Q=0.1"], "unknown parameter 'Q'"),
    (["--tol", "T"], "expected PARAMETER=FRACTION"),
    (["--workers", "0"], "workers must be at least 1"),
    (["--param-tol", "-1"], "param_tol is -1.0"),
    (["--mse-tol", "nan"], "mse_tol is nan"),
    (["--tol", "T=-0.1"], "tolerance of T is -0.1"),
    (["--baseline", "nowhere.json"], "results file not found"),
    (["--junit", "."], "cannot write the JUnit file"),
    (["--executor", "spark"], "unknown executor"),
])
def test_bad_run_options_are_one_line(tmp_path, extra, needle):
    c = _config(tmp_path, f"name: t\ndata:\n  path: {_csv(tmp_path).name}\n  input: u\n"
                "  output: y\n  time: time\nmethods: [first_order]\n")
    _one_line_error(runner.invoke(app, ["run", str(c), "--out", str(tmp_path / "o"), *extra]),
                    needle)
    assert not (tmp_path / "o").exists()


# -- data options ------------------------------------------------------------------------

def _identify(path, *extra):
    return runner.invoke(app, ["identify", str(path), *extra])


@pytest.mark.parametrize("methods", [["--method", "first_order,smith"],
                                     ["--method", "first_order", "--method", "smith"]])
def test_method_lists(tmp_path, methods):
    r = _identify(_csv(tmp_path), "--input", "u", "--output", "y", "--time", "time",
                  *methods, "--events", "0,1", "--json")
    assert r.exit_code == 0, r.output
    fits = json.loads(r.stdout)["records"][0]["fits"]
    assert sorted({f["method"] for f in fits}) == ["first_order", "smith"]
    assert {f["event"] for f in fits} == {0, 1}


@pytest.mark.parametrize("extra", [["--method", "first_order", "smith"],
                                   ["--events", "0", "1"]])
def test_two_words_for_a_list_is_one_line(tmp_path, extra):
    r = _identify(_csv(tmp_path), "--input", "u", "--output", "y", "--time", "time", *extra)
    _one_line_error(r, "unexpected argument", "with commas (--method first_order,smith",
                    "repeat the option")


def test_time_and_sample_time_exclude_each_other(tmp_path):
    p = _csv(tmp_path)
    r = _identify(p, "--input", "u", "--output", "y", "--time", "time", "--sample-time", "0.1")
    _one_line_error(r, f"{p}: --sample-time: a sample time and a time column exclude each "
                    "other; give one (got 0.1)")


def test_data_options_reach_the_reader(tmp_path):
    """--format, --no-header, positions, --delimiter and --decimal, --time-unit."""
    src = _csv(tmp_path).read_text().splitlines()[1:]
    p = tmp_path / "export.log"
    p.write_text("\n".join(line.replace(",", ";").replace(".", ",") for line in src) + "\n")
    args = ["--input", "1", "--output", "2", "--time", "0", "--method", "first_order", "--json"]
    r = _identify(p, *args, "--format", "tsv", "--no-header", "--delimiter", ";",
                  "--decimal", ",")
    assert r.exit_code == 0, r.output
    fit = json.loads(r.stdout)["records"][0]["fits"][0]
    assert fit["params"]["K"] == pytest.approx(2.5, rel=0.02)
    r = _identify(p, *args, "--format", "tsv", "--time-unit", "min")
    assert r.exit_code == 0, r.output
    rec = json.loads(r.stdout)["records"][0]
    assert rec["units"]["time"] == "min" and rec["events"][0]["t0"] == pytest.approx(13.7 * 60)
    r = _identify(p, *args, "--format", "tsv", "--sheet", "1")
    _one_line_error(r, f"{p}: --sheet does not apply to csv files (it is an option of: xlsx)")
    _one_line_error(_identify(p, *args), f"{p}: unknown file type '.log'")


def test_start_is_in_results_json(tmp_path):
    from tests.forms import FORMS, synthetic_log

    path, _ = FORMS["datetime_local_dst"][0](synthetic_log(), tmp_path)
    r = _identify(path, "--input", "u", "--output", "y", "--time", "time", "--time-zone",
                  "Europe/Berlin", "--method", "first_order", "--json")
    assert r.exit_code == 0, r.output
    rec = json.loads(r.stdout)["records"][0]
    assert rec["start"] == "2024-10-27T02:58:00+02:00"
    assert [round(e["t0"], 1) for e in rec["events"]] == [13.7, 113.7]


def _bad_variants(tmp_path):
    from tests.forms import FORMS, synthetic_log

    log = synthetic_log()
    xlsx, _ = FORMS["xlsx"][0](log, tmp_path)
    mat, _ = FORMS["mat_v5"][0](log, tmp_path)
    mixed = tmp_path / "mixed.csv"
    mixed.write_text("time,1.5,y\n" + "".join(f"{i / 10},1,2\n" for i in range(20)))
    stamps = tmp_path / "stamps.csv"
    stamps.write_text("time,u,y\n" + "".join(f"2024-10-27 02:{i:02d}:00,1,2\n" for i in range(9))
                      + "2024-10-27 02:61:00,1,2\n")
    return [
        (mixed, ["--time", "time"], f"{mixed}: line 1 mixes names and numbers ('time', '1.5', "
         "'y'): cannot tell whether it is a header; expected a header of names or a row of "
         "numbers, or set header: true or false (--header / --no-header)"),
        (xlsx, ["--time", "time", "--sheet", "Data"],
         f"{xlsx}: no sheet 'Data'; the sheets are 'Info', 'Log'"),
        (mat, ["--time", "Zeit", "--output", "Speed"],
         f"{mat}: no variable 'Speed'; the variables are 'Zeit', 'u', 'y'"),
        (mat, ["--time", "Ts"], f"{mat}: variable 'Ts' has 1 value(s), where the signals have "
         "2138 samples"),
        (stamps, ["--time", "time"], f"{stamps}: line 11: time column 'time' has "
         "'2024-10-27 02:61:00'; expected a number or an ISO-8601 date-time such as "
         "2024-10-27T02:30:00+02:00 (or set time_format)"),
    ]


def test_bad_variants_are_one_line_naming_file_and_expectation(tmp_path):
    for path, extra, expected in _bad_variants(tmp_path):
        args = ["--input", "u", "--output", "y", *extra]
        r = _identify(path, *args)
        _one_line_error(r)
        assert r.stderr.strip() == f"error: {expected}"


@pytest.mark.skipif(not have_mirror(), reason="needs the dataset mirror")
@pytest.mark.parametrize("name,signals", [
    ("daniw-dc-step", ["Motorspannung", "Geschwindigkeit"]),
    ("daniw-level-step", ["PumpeRechts", "NiveauTank2"]),
])
def test_real_mat_logs_through_the_registry(name, signals):
    from pipeline.io.datasets import fetch

    r = _identify(fetch(name), "--input", signals[0], "--output", signals[1], "--time", "Zeit",
                  "--method", "first_order", "--json")
    assert r.exit_code == 0, r.output
    (fit,) = json.loads(r.stdout)["records"][0]["fits"]
    assert fit["status"] == "ok" and fit["params"]["K"] > 0


def test_help_names_every_format_and_data_option():
    """The help is written out (the CLI starts without importing the loaders): it must
    name every format, alias and suffix of the registry, and each data option is a key."""
    from pipeline.cli.data import DATA_OPTIONS, flag
    from pipeline.io import FORMATS, DataConfig

    r = runner.invoke(app, ["identify", "--help"])
    assert r.exit_code == 0
    text = " ".join(r.output.split())
    for fmt in FORMATS.values():
        for word in (fmt.name, *fmt.aliases, *fmt.suffixes):
            assert word in text, word
    for name, _, _ in DATA_OPTIONS:
        assert name in DataConfig.model_fields and flag(name) in text


@pytest.mark.parametrize("args", [
    ["methods"], ["schema"], ["datasets", "list"],
    ["identify", "LOG", "--input", "u", "--output", "y", "--time", "time",
     "--method", "first_order"],
])
def test_a_closed_stdout_exits_141_quietly(tmp_path, args):
    """``pipeline ... | head -1``: the reader gone before the command writes. Exit code
    141 (128 + SIGPIPE, as a shell reports it), never 1 (a regression to a gate), and no
    traceback or 'Exception ignored' on stderr (issue 29)."""
    import os

    args = [str(_csv(tmp_path)) if a == "LOG" else a for a in args]
    read_end, write_end = os.pipe()
    os.close(read_end)  # every write to stdout now fails with EPIPE
    try:
        r = subprocess.run([sys.executable, "-m", "pipeline", *args], stdout=write_end,
                           stderr=subprocess.PIPE, text=True, timeout=120)
    finally:
        os.close(write_end)
    assert r.returncode == 141, r.stderr
    assert r.stderr == "", r.stderr


@pytest.mark.skipif(not Path("/dev/full").exists(), reason="needs /dev/full")
@pytest.mark.parametrize("args", [
    ["methods", "--json"], ["schema"], ["--version"], ["--help"], ["identify", "--help"],
    ["identify", "LOG", "--input", "u", "--output", "y", "--time", "time",
     "--method", "first_order", "--json"],
])
def test_a_full_stdout_is_one_line_and_exit_2(tmp_path, args):
    """``--json > /dev/full``: every write fails with ENOSPC. One line on stderr naming
    standard output, exit code 2, no traceback or 'Exception ignored' (issue 31)."""
    args = [str(_csv(tmp_path)) if a == "LOG" else a for a in args]
    with open("/dev/full", "w") as full:
        r = subprocess.run([sys.executable, "-m", "pipeline", *args], stdout=full,
                           stderr=subprocess.PIPE, text=True, timeout=120)
    assert r.returncode == 2, r.stderr
    assert r.stderr == "error: cannot write standard output: No space left on device\n", \
        r.stderr
