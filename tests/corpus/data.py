"""Corpus rows for data pathologies and file names (issue 13 items 1, 15, 16; issue 14).

A file name with glob characters is that file; values that overflow squared errors, an
infinite value, time that goes back or repeats, an empty or text column:
one line naming the file; Unix-epoch stamps, a BOM, CRLF line ends and a huge header
line are read as the plain logs they are.
"""

from __future__ import annotations

import json
from pathlib import Path

from tests.corpus import Hostile, config, step_csv

IDENTIFY = ("identify", "log.csv", "--input", "u", "--output", "y", "--time", "time",
            "--method", "first_order")


def _rows(text: str) -> list[list[str]]:
    return [line.split(",") for line in text.splitlines()[1:]]


def _scaled(factor: float) -> str:
    """step_csv() with u and y multiplied by ``factor`` (the same plant in other units)."""
    rows = _rows(step_csv())
    lines = ["time,u,y"] + [f"{t},{float(u) * factor!r},{float(y) * factor!r}"
                            for t, u, y in rows]
    return "\n".join(lines) + "\n"


def _with_y(at: int, value: str) -> str:
    """step_csv() with the output of data row ``at`` replaced."""
    rows = _rows(step_csv())
    rows[at][2] = value
    return "time,u,y\n" + "".join(",".join(r) + "\n" for r in rows)


def _gain(out: str, expected: float) -> callable:
    """A check: the run's first fit in ``out/results.json`` has gain ``expected``."""
    def check(folder: Path) -> None:
        doc = json.loads((folder / out / "results.json").read_text())
        fits = [f for r in doc["records"] for f in r["fits"] if f["status"] == "ok"]
        assert len(doc["records"]) == 1, [r["source"] for r in doc["records"]]
        assert abs(fits[0]["params"]["K"] / expected - 1) < 0.03, fits[0]["params"]
    return check


def _glob_row(kind: str, literal: str, other: str) -> Hostile:
    """``data.path`` names a file whose name has glob characters, beside the file the
    pattern would match (another plant, K = 5): the run reads the named one (K = 2)."""
    return Hostile(
        kind, ("run", "c.yaml", "--out", "out"), 0,
        files={"c.yaml": config(f"path: '{literal}'\ninput: u\noutput: y\ntime: time"),
               literal: step_csv(K=2.0), other: step_csv(K=5.0, seed=3)},
        keep=(literal, other), max_lines=3, check=_gain("out", 2.0))


def _epoch_csv() -> str:
    rows = _rows(step_csv(dt=0.1, n=2000, steps=((20.0, 1.0), (110.0, 0.0))))
    return "time,u,y\n" + "".join(f"{1.7e9 + 0.1 * i:.1f},{u},{y}\n"
                                  for i, (_, u, y) in enumerate(rows))


def _json_gain(expected: float, sample_time: float | None = None) -> callable:
    def check(folder: Path) -> None:
        doc = json.loads((folder / "res" / "results.json").read_text())
        rec = doc["records"][0]
        assert abs(rec["fits"][0]["params"]["K"] / expected - 1) < 0.03
        if sample_time is not None:
            assert abs(rec["sample_time"] / sample_time - 1) < 1e-9, rec["sample_time"]
    return check


GOOD = step_csv()
HUGE_HEADER = "time,u,y," + "x" * 200_000 + "\n" + "".join(
    line + ",0\n" for line in GOOD.splitlines()[1:])

CASES = [
    # extreme magnitudes: femto-units identify like any others; below 1e-150 the squared
    # errors underflow (a K = 0 fit with MSE 0 would look perfect): refused in one line
    Hostile("data_femto_units_identify", (*IDENTIFY, "--out", "res"), 0,
            files={"log.csv": _scaled(1e-100)}, max_lines=0, check=_json_gain(2.0)),
    Hostile("data_values_underflow_refused", IDENTIFY, 2, files={"log.csv": _scaled(1e-300)},
            stderr=("log.csv", "column 'u'", "underflow", "scale the signal")),
    Hostile("data_1e50_units_identify_quietly", (*IDENTIFY, "--out", "res"), 0,
            files={"log.csv": _scaled(1e50)}, max_lines=0, check=_json_gain(2.0)),

    _glob_row("data_glob_brackets_name_is_literal", "run[1].csv", "run1.csv"),
    _glob_row("data_glob_star_name_is_literal", "a*.csv", "ab.csv"),
    _glob_row("data_glob_question_name_is_literal", "r?n.csv", "run.csv"),
    Hostile("data_value_near_1e308", IDENTIFY, 2, files={"log.csv": _with_y(100, "1e308")},
            stderr=("log.csv", "column 'y'", "scale the signal"), keep=("log.csv",)),
    Hostile("data_value_1e200_squared_overflows", IDENTIFY, 2,
            files={"log.csv": _with_y(50, "-1e200")},
            stderr=("log.csv", "column 'y'", "scale the signal")),
    Hostile("data_inf_is_a_drop_out", IDENTIFY, 2, files={"log.csv": _with_y(100, "inf")},
            stderr=("log.csv: line 102", "'y' is inf", "fill_gaps")),
    Hostile("data_inf_filled_as_nan_would_be", (*IDENTIFY, "--fill-gaps", "1", "--json"), 0,
            files={"log.csv": _with_y(100, "-inf")}, max_lines=0),
    Hostile("data_epoch_stamps_are_regular", (*IDENTIFY, "--out", "res"), 0,
            files={"log.csv": _epoch_csv()}, max_lines=3, check=_json_gain(2.0, 0.1)),
    Hostile("data_time_goes_back", IDENTIFY, 2,
            files={"log.csv": GOOD.replace("\n10,", "\n9,", 1)},
            stderr=("log.csv: line 22", "not strictly increasing")),
    Hostile("data_duplicate_time_stamps", IDENTIFY, 2,
            files={"log.csv": GOOD.replace("\n10,", "\n9.5,", 1)},
            stderr=("log.csv: line 22", "repeats", "duplicates")),
    Hostile("data_all_nan_column", IDENTIFY, 2,
            files={"log.csv": "time,u,y\n" + "".join(f"{r[0]},{r[1]},nan\n"
                                                     for r in _rows(GOOD))},
            stderr=("log.csv: line 2", "column 'y' holds no number on any row")),
    Hostile("data_column_of_strings", IDENTIFY, 2,
            files={"log.csv": "time,u,y\n" + "".join(f"{r[0]},{r[1]},high\n"
                                                     for r in _rows(GOOD))},
            stderr=("log.csv: line 2", "'high'", "expected a number")),
    Hostile("data_huge_header_line", (*IDENTIFY, "--json"), 0,
            files={"log.csv": HUGE_HEADER}, max_lines=0),
    Hostile("data_utf8_bom", (*IDENTIFY, "--json"), 0,
            files={"log.csv": "\ufeff" + GOOD}, max_lines=0),
    Hostile("data_crlf_line_ends", (*IDENTIFY, "--out", "res"), 0,
            files={"log.csv": GOOD.replace("\n", "\r\n").encode()}, max_lines=3,
            check=_json_gain(2.0, 0.5)),
    Hostile("data_file_is_a_directory", IDENTIFY, 2, files={"log.csv/inside.txt": "x"},
            stderr=("log.csv", "is a folder")),
    Hostile("data_config_path_is_a_directory_of_nothing", ("run", "c.yaml"), 2,
            files={"c.yaml": config("path: logs\ninput: u\noutput: y\ntime: time"),
                   "logs/notes.md": "no logs here"},
            stderr=("c.yaml", "data.path", "matches no file")),
]
