"""Tabular logs: CSV (through polars) and whitespace-separated ``.dat`` files (DaISy).

CSV: a header row; comment lines starting with ``#`` are skipped; an unnamed first column
(the index pandas writes) is ignored; the time column is named, or a sample time is given.
``.dat``: whitespace separated, no header; the columns are named by the config or the
dataset registry (DaISy: ``time u y``).
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import polars as pl

from ..errors import UserError
from ..record import Record, make_record


def read_csv_frame(path: Path) -> pl.DataFrame:
    """The CSV as a polars frame; a malformed file is one :class:`UserError` line."""
    try:
        df = pl.read_csv(path, comment_prefix="#", infer_schema_length=None,
                         truncate_ragged_lines=False)
    except FileNotFoundError:
        raise UserError(f"{path}: file not found") from None
    except pl.exceptions.NoDataError:
        raise UserError(f"{path}: the file is empty; expected a CSV with a header row") from None
    except (pl.exceptions.PolarsError, UnicodeDecodeError, OSError) as exc:
        first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise UserError(f"{path}: not a readable CSV ({first})") from None
    if df.height == 0:
        raise UserError(f"{path}: no data rows after the header")
    return df


def read_dat_frame(path: Path, columns: list[str]) -> pl.DataFrame:
    """A whitespace-separated numeric table without header (DaISy ``.dat``)."""
    try:
        arr = np.loadtxt(path, comments="#", ndmin=2, dtype=np.float64)
    except FileNotFoundError:
        raise UserError(f"{path}: file not found") from None
    except ValueError as exc:
        raise UserError(f"{path}: {_loadtxt_problem(exc)}; expected whitespace-separated "
                        "numbers") from None
    if arr.size == 0:
        raise UserError(f"{path}: the file is empty; expected whitespace-separated numbers")
    if arr.shape[1] != len(columns):
        raise UserError(
            f"{path}: {arr.shape[1]} columns per line, but {len(columns)} column names "
            f"were given ({', '.join(columns)})"
        )
    return pl.DataFrame({name: arr[:, i] for i, name in enumerate(columns)})


def frame_to_record(df: pl.DataFrame, path: Path, *, input: str, output: str,
                    time: str | None, sample_time: float | None,
                    initial_input: float | None, units: dict[str, str], name: str,
                    data_offset: int = 2) -> Record:
    """Pick the named columns of ``df`` as a :class:`Record`.

    ``data_offset`` is the file line of the first data row (for error messages).
    """
    wanted = [c for c in (time, input, output) if c is not None]
    missing = [c for c in wanted if c not in df.columns]
    if missing:
        cols = ", ".join(repr(c) for c in df.columns if c)
        raise UserError(f"{path}: no column {missing[0]!r}; the columns are {cols}")
    if time is None and sample_time is None:
        raise UserError(f"{path}: neither a time column nor a sample_time was given")
    arrays = {c: _numeric(df, c, path, data_offset) for c in wanted}
    t = arrays[time] if time is not None else np.arange(df.height) * float(sample_time)
    return make_record(t, arrays[input], arrays[output], name=name, source=str(path),
                       units=units, initial_input=initial_input, input_name=input,
                       output_name=output)


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


def first_data_line(path: Path) -> int:
    """1-based line number of the first data row of a CSV (after comments and header)."""
    with open(path, encoding="utf-8", errors="replace") as fh:
        for i, line in enumerate(fh, start=1):
            if line.strip() and not line.lstrip().startswith("#"):
                return i + 1  # the header is this line
    return 2


def _loadtxt_problem(exc: ValueError) -> str:
    """numpy.loadtxt's message with its 0-based data row turned into the file line."""
    text = _one_line(exc).rstrip(".")
    m = re.search(r"could not convert string '(.*)' to \w+ at row (\d+), column (\d+)", text)
    if m:
        return f"line {int(m.group(2)) + 1}, column {m.group(3)}: {m.group(1)!r} is not a number"
    m = re.search(r"the number of columns changed from (\d+) to (\d+) at row (\d+)", text)
    if m:
        return (f"line {int(m.group(3))}: {m.group(2)} columns where the lines before have "
                f"{m.group(1)}")
    return text


def _one_line(exc: Exception) -> str:
    text = str(exc).strip()
    return text.splitlines()[0] if text else type(exc).__name__
