"""Corpus rows for workbooks and columnar files as users have them (issue 31): formulas
never calculated, an empty first sheet, numbers stored as dictionary-encoded text.

A library such as xlsxwriter stores 0 beside each formula and asks the spreadsheet to
recalculate on opening; read as numbers, the output became a column of zeros with status
ok. Refused with the cell named, as is a formula with no stored value at all; the
stay-ok twin is the same workbook as a spreadsheet saves it (calculated values, no
request to recalculate), which loads with its values.
"""

from __future__ import annotations

import io
import json
import re
import zipfile
from pathlib import Path

from tests.corpus import Hostile, step_csv

IDENTIFY = ("identify", "log.xlsx", "--input", "u", "--output", "y", "--time", "time",
            "--method", "first_order", "--out", "out")


def _rows() -> list[tuple[float, float, float]]:
    return [tuple(map(float, line.split(","))) for line in step_csv().splitlines()[1:]]


def _workbook(*, formulas: bool) -> bytes:
    """The step log as a workbook; with ``formulas``, y is ``=<value>*1`` in every row,
    stored with the value a spreadsheet would have calculated."""
    import xlsxwriter

    out = io.BytesIO()
    with xlsxwriter.Workbook(out, {"in_memory": True}) as book:
        sheet = book.add_worksheet("log")
        sheet.write_row(0, 0, ["time", "u", "y"])
        for i, (t, u, y) in enumerate(_rows(), start=1):
            sheet.write_row(i, 0, [t, u])
            if formulas:
                sheet.write_formula(i, 2, f"={y!r}*1", None, y)
            else:
                sheet.write_number(i, 2, y)
    return out.getvalue()


def _edited(data: bytes, part: str, edit) -> bytes:
    """``data`` (a zip) with ``part`` replaced by ``edit(part's bytes)``."""
    src, out = zipfile.ZipFile(io.BytesIO(data)), io.BytesIO()
    with zipfile.ZipFile(out, "w", zipfile.ZIP_DEFLATED) as dst:
        for item in src.infolist():
            body = src.read(item.filename)
            dst.writestr(item, edit(body) if item.filename == part else body)
    return out.getvalue()


def _as_saved(data: bytes) -> bytes:
    """What a spreadsheet saves: the calculated values kept, no request to recalculate."""
    return _edited(data, "xl/workbook.xml",
                   lambda b: b.replace(b' fullCalcOnLoad="1"', b""))


def _placeholders(data: bytes) -> bytes:
    """What xlsxwriter writes when no value is given: 0 beside every formula."""
    return _edited(data, "xl/worksheets/sheet1.xml",
                   lambda b: re.sub(rb"(</f>)<v>[^<]*</v>", rb"\1<v>0</v>", b))


def _no_values(data: bytes) -> bytes:
    """Formulas with no stored value at all, and no request to recalculate."""
    return _as_saved(_edited(data, "xl/worksheets/sheet1.xml",
                             lambda b: re.sub(rb"(</f>)<v>[^<]*</v>", rb"\1", b)))


def _gain(folder: Path) -> None:
    doc = json.loads((folder / "out" / "results.json").read_text())
    fit = doc["records"][0]["fits"][0]
    assert abs(fit["params"]["K"] / 2.0 - 1) < 0.03, fit["params"]


CASES = [
    Hostile("xlsx_formulas_left_to_recalculate", IDENTIFY, 2,
            files={"log.xlsx": _placeholders(_workbook(formulas=True))},
            stderr=("log.xlsx: sheet 'log' cell C2 is a formula whose value was never "
                    "calculated",), keep=("log.xlsx",), max_lines=1),
    Hostile("xlsx_formulas_without_values", IDENTIFY, 2,
            files={"log.xlsx": _no_values(_workbook(formulas=True))},
            stderr=("cell C2 is a formula",), keep=("log.xlsx",), max_lines=1),
    Hostile("xlsx_formulas_calculated", IDENTIFY, 0,
            files={"log.xlsx": _as_saved(_workbook(formulas=True))},
            keep=("log.xlsx",), check=_gain),
    Hostile("xlsx_plain_values", IDENTIFY, 0,
            files={"log.xlsx": _workbook(formulas=False)}, keep=("log.xlsx",), check=_gain),
]


def _empty_first_sheet() -> bytes:
    """A workbook whose first sheet is empty and whose second holds the step log."""
    import xlsxwriter

    out = io.BytesIO()
    with xlsxwriter.Workbook(out, {"in_memory": True}) as book:
        book.add_worksheet("notes")
        sheet = book.add_worksheet("log")
        sheet.write_row(0, 0, ["time", "u", "y"])
        for i, row in enumerate(_rows(), start=1):
            sheet.write_row(i, 0, row)
    return out.getvalue()


def _dictionary_parquet() -> bytes:
    """The step log as Parquet, u and y dictionary-encoded text (Categorical, Enum)."""
    import polars as pl

    t, u, y = zip(*_rows(), strict=True)
    frame = pl.DataFrame({"time": t, "u": [f"{v:g}" for v in u], "y": [repr(v) for v in y]})
    frame = frame.with_columns(pl.col("u").cast(pl.Categorical),
                               pl.col("y").cast(pl.Enum(sorted(set(frame["y"])))))
    out = io.BytesIO()
    frame.write_parquet(out)
    return out.getvalue()


CASES += [
    Hostile("xlsx_empty_first_sheet", IDENTIFY, 2,
            files={"log.xlsx": _empty_first_sheet()},
            stderr=("log.xlsx: sheet 'notes' is empty; expected a table (the other sheets: "
                    "'log'; choose one with data.sheet or --sheet)",), keep=("log.xlsx",),
            max_lines=1),
    Hostile("xlsx_empty_first_sheet_chosen", (*IDENTIFY, "--sheet", "log"), 0,
            files={"log.xlsx": _empty_first_sheet()}, keep=("log.xlsx",), check=_gain),
    Hostile("parquet_dictionary_encoded_numbers",
            ("identify", "log.parquet", "--input", "u", "--output", "y", "--time", "time",
             "--method", "first_order", "--out", "out"), 0,
            files={"log.parquet": _dictionary_parquet()}, keep=("log.parquet",), check=_gain),
]
