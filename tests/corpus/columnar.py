"""Corpus rows for Parquet columns that hold more than a number per row (issue 31): a list,
a fixed-size array or a struct in the output column is one line naming the column and its
type; the same table with plain numbers is identified (the twin)."""

from __future__ import annotations

import io

import polars as pl

from tests.corpus import Hostile, step_csv

IDENTIFY = ("identify", "log.parquet", "--input", "u", "--output", "y", "--time", "time",
            "--method", "first_order")
FLAT = pl.read_csv(io.StringIO(step_csv()))


def _parquet(frame: pl.DataFrame) -> bytes:
    buf = io.BytesIO()
    frame.write_parquet(buf)
    return buf.getvalue()


def _nested(kind: str) -> bytes:
    y = {"list": pl.concat_list("y"), "array": pl.concat_list("y").cast(pl.Array(pl.Float64, 1)),
         "struct": pl.struct("y")}[kind]
    return _parquet(FLAT.with_columns(y.alias("y")))


CASES = [
    Hostile("parquet_flat_numbers_identify", (*IDENTIFY, "--json"), 0,
            files={"log.parquet": _parquet(FLAT)}, keep=("log.parquet",)),
    *(Hostile(f"parquet_{kind}_column_refused", IDENTIFY, 2,
              files={"log.parquet": _nested(kind)}, keep=("log.parquet",), max_lines=1,
              stderr=("log.parquet", "column 'y' holds", "expected one number per row"))
      for kind in ("list", "array", "struct")),
]
