"""What the tabular formats (:mod:`.csv`, :mod:`.dat`) share: their time keys and the step
from a table of named columns to a :class:`~pipeline.record.Record`.

Keys: ``time`` (the time column, seconds) or ``sample_time`` (seconds between rows, when
there is no time column); ``input`` and ``output`` are column names.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import polars as pl
from pydantic import Field

from ..errors import UserError
from ..record import Record, make_record
from .base import DataSection, Strict


class TableOptions(Strict):
    """The time base of a table: a time column, or a sample time."""

    time: str | None = None
    sample_time: float | None = Field(None, gt=0)


def check_columns(path: Path, data: DataSection, fmt: str) -> None:
    """A table's input and output are column names (not MCAP topics)."""
    if not isinstance(data.input, str) or not isinstance(data.output, str):
        raise UserError(f"{path}: a {fmt} file's input and output are column names")


def frame_to_record(df: pl.DataFrame, path: Path, data: DataSection, options: TableOptions,
                    name: str, data_offset: int = 2) -> Record:
    """Pick the named columns of ``df`` as a :class:`Record`.

    ``data_offset`` is the file line of the first data row (for error messages).
    """
    input, output, time = data.input, data.output, options.time
    wanted = [c for c in (time, input, output) if c is not None]
    missing = [c for c in wanted if c not in df.columns]
    if missing:
        cols = ", ".join(repr(c) for c in df.columns if c)
        raise UserError(f"{path}: no column {missing[0]!r}; the columns are {cols}")
    if time is None and options.sample_time is None:
        raise UserError(f"{path}: neither a time column nor a sample_time was given")
    arrays = {c: _numeric(df, c, path, data_offset) for c in wanted}
    t = (arrays[time] if time is not None
         else np.arange(df.height) * float(options.sample_time))
    return make_record(t, arrays[input], arrays[output], name=name, source=str(path),
                       units=data.unit_map(), initial_input=data.initial_input,
                       input_name=input, output_name=output)


def _numeric(df: pl.DataFrame, col: str, path: Path, data_offset: int) -> np.ndarray:
    s = df[col]
    cast = s.cast(pl.Float64, strict=False)
    bad = (cast.is_null() & ~s.is_null()) | s.is_null()
    if bad.any():
        row = int(bad.arg_max())
        val = s[row]
        raise UserError(
            f"{path}: line {row + data_offset}: column {col!r} has "
            f"{'an empty value' if val is None else repr(str(val))}; expected a number"
        )
    return cast.to_numpy().astype(np.float64)


def one_line(exc: Exception) -> str:
    """The first line of a library's error message (its type when it has none)."""
    text = str(exc).strip()
    return text.splitlines()[0] if text else type(exc).__name__
