"""Corpus rows for the regression gate and the history (issue 13 items 11 and 13): bad
baselines, a baseline of another config, tolerances that would switch the gate off or
fire on everything, and a parquet file that is not our history (kept byte for byte)."""

import io
import json
from datetime import UTC, datetime
from pathlib import Path

import polars as pl

from tests.corpus import Hostile, config, step_csv

CFG = config("path: log.csv\ninput: u\noutput: y\ntime: time")
FILES = {"c.yaml": CFG, "log.csv": step_csv()}
RUN = ("run", "c.yaml", "--out", "{d}/out", "--workers", "1")


def _baseline(config_name: str = "c.yaml", record: str = "log", method: str = "first_order"
              ) -> str:
    fit = {"method": method, "event": 0, "status": "ok", "structure": "first_order",
           "params": {"K": 2.0, "T": 5.0}}
    return json.dumps({"schema_version": "2", "pipeline_version": "0.1", "config": config_name,
                       "records": [{"name": record, "source": f"{record}.csv", "status": "ok",
                                    "fits": [fit]}]})


def _parquet(frame: pl.DataFrame) -> bytes:
    buf = io.BytesIO()
    frame.write_parquet(buf)
    return buf.getvalue()


#: time and record columns, but not our types (the old check accepted and rewrote it)
FOREIGN = _parquet(pl.DataFrame({"time": ["2024-01-01T00:00:00"], "record": [7],
                                 "method": ["x"], "temperature": [21.5]}))
OURS_NS = _parquet(pl.DataFrame({"time": [datetime(2024, 1, 1, tzinfo=UTC)], "record": ["log"],
                                 "method": ["first_order"]}).with_columns(
    pl.col("time").dt.cast_time_unit("ns")))


def no_report(d: Path) -> None:
    assert not (d / "out").exists(), "a refused run wrote a report"


def no_baseline_written(d: Path) -> None:
    assert not (d / "b.json").exists(), "a bad results file was accepted"


def gate_ran(d: Path) -> None:
    md = (d / "out" / "report.md").read_text()
    assert "## Regressions against the baseline" in md and "| vs baseline |" in md


def _bad(kind: str, content: str, needle: str) -> Hostile:
    return Hostile(kind, (*RUN, "--baseline", "b.json"), 2, files={**FILES, "b.json": content},
                   stderr=("b.json", needle), keep=("b.json",), max_lines=1, check=no_report)


def _tol(kind: str, option: tuple[str, ...], needle: str) -> Hostile:
    return Hostile(kind, (*RUN, "--baseline", "b.json", *option), 2,
                   files={**FILES, "b.json": _baseline()}, stderr=(needle,), max_lines=1,
                   check=no_report)


CASES = [
    _bad("baseline_not_json", "{not json", "not valid JSON"),
    _bad("baseline_json_list", "[1, 2, 3]", "expected an object with a 'records' list"),
    _bad("baseline_wrong_shape", json.dumps({"pipeline_version": "1",
                                             "records": [{"name": 1, "status": "maybe"}]}),
         "not a valid results.json"),
    _bad("baseline_nested_too_deep", '{"records": ' + "[" * 100_000 + "]" * 100_000 + "}",
         "nested too deeply"),
    _bad("baseline_bad_schema_version", json.dumps({"schema_version": "99",
                                                    "pipeline_version": "9", "records": []}),
         "schema_version '99'"),
    _bad("baseline_of_another_config", _baseline("configs/other.yaml"),
         "a baseline of config 'configs/other.yaml', not of this run's 'c.yaml'"),
    _bad("baseline_shares_no_record", _baseline(record="elsewhere"),
         "shares no record with this run"),
    _bad("baseline_shares_no_method", _baseline(method="smith"),
         "no fit in the baseline is of a method this config runs"),
    Hostile("baseline_same_config_elsewhere_compares",
            (*RUN, "--baseline", "b.json"), 0,
            files={**FILES, "b.json": _baseline("/ci/checkout/c.yaml")}, keep=("b.json",),
            max_lines=0, check=gate_ran),
    _tol("param_tol_nan", ("--param-tol", "nan"), "--param-tol nan"),
    _tol("param_tol_negative", ("--param-tol", "-1"), "--param-tol -1.0"),
    _tol("param_tol_inf", ("--param-tol", "inf"), "--param-tol inf"),
    _tol("mse_tol_nan", ("--mse-tol", "nan"), "--mse-tol nan"),
    _tol("tol_nan", ("--tol", "K=nan"), "--tol 'K=nan': tolerance of K is nan"),
    _tol("tol_negative", ("--tol", "T=-0.2"), "--tol 'T=-0.2'"),
    _tol("tol_bogus", ("--tol", "bogus"), "expected PARAMETER=FRACTION"),
    _tol("tol_no_value", ("--tol", "K="), "expected PARAMETER=FRACTION"),
    _tol("tol_unknown_parameter", ("--tol", "gain=0.1"), "unknown parameter 'gain'"),
    Hostile("history_foreign_parquet_kept", (*RUN, "--history", "h.parquet"), 2,
            files={**FILES, "h.parquet": FOREIGN}, keep=("h.parquet",), max_lines=1,
            stderr=("h.parquet", "not a pipeline history file", "column 'time' is String"),
            check=no_report),
    Hostile("history_other_time_unit_kept", (*RUN, "--history", "h.parquet"), 2,
            files={**FILES, "h.parquet": OURS_NS}, keep=("h.parquet",), max_lines=1,
            stderr=("h.parquet", "column 'time' is Datetime"), check=no_report),
    Hostile("history_not_parquet_kept", (*RUN, "--history", "h.parquet"), 2,
            files={**FILES, "h.parquet": b"PAR1 but not really"}, keep=("h.parquet",),
            max_lines=1, stderr=("h.parquet", "not a readable parquet"), check=no_report),
    Hostile("baseline_accept_not_results", ("baseline", "accept", "r.json", "--to", "b.json"),
            2, files={"r.json": "[" * 100_000}, keep=("r.json",), max_lines=1,
            stderr=("r.json", "nested too deeply"), check=no_baseline_written),
]
