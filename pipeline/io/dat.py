"""Whitespace-separated numeric tables without a header (DaISy ``.dat``, ``.txt``).

``#`` starts a comment. The columns are named by ``columns`` (default ``time u y``, the
DaISy layout), from the config or the dataset registry.

Keys (``data:``, beside the common ones): ``columns``, and ``time`` (one of the column
names) or ``sample_time`` (seconds between rows); ``input`` and ``output`` are column
names.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import polars as pl
from pydantic import Field

from ..errors import UserError
from ..record import Record
from .base import DataSection, Format
from .table import TableOptions, check_columns, frame_to_record, one_line


class DatOptions(TableOptions):
    """The keys of a ``.dat`` file: the column names, and ``time`` or ``sample_time``."""

    columns: list[str] = Field(["time", "u", "y"], min_length=1)


def load_dat(path: Path, data: DataSection, options: DatOptions, name: str) -> Record:
    """One ``.dat`` table as a :class:`Record`, its columns named by ``options.columns``."""
    check_columns(path, data, "dat")
    return frame_to_record(read_dat_frame(path, options.columns), path, data, options, name,
                           data_offset=1)


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


def _loadtxt_problem(exc: ValueError) -> str:
    """numpy.loadtxt's message with its 0-based data row turned into the file line."""
    text = one_line(exc).rstrip(".")
    m = re.search(r"could not convert string '(.*)' to \w+ at row (\d+), column (\d+)", text)
    if m:
        return f"line {int(m.group(2)) + 1}, column {m.group(3)}: {m.group(1)!r} is not a number"
    m = re.search(r"the number of columns changed from (\d+) to (\d+) at row (\d+)", text)
    if m:
        return (f"line {int(m.group(3))}: {m.group(2)} columns where the lines before have "
                f"{m.group(1)}")
    return text


FORMAT = Format("dat", (".dat", ".txt"), DatOptions, load_dat)
