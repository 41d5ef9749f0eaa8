"""CSV logs, read with polars.

A header row; comment lines starting with ``#`` are skipped; an unnamed first column (the
index pandas writes) is ignored.

Keys (``data:``, beside the common ones): ``time`` (the time column) or ``sample_time``
(seconds between rows); ``input`` and ``output`` are column names.
"""

from __future__ import annotations

from pathlib import Path

import polars as pl

from ..errors import UserError
from ..record import Record
from .base import DataSection, Format
from .table import TableOptions, check_columns, frame_to_record, one_line


class CsvOptions(TableOptions):
    """The keys of a CSV file: ``time`` or ``sample_time``."""


def load_csv(path: Path, data: DataSection, options: CsvOptions, name: str) -> Record:
    """One CSV log as a :class:`Record` (the input and output columns, the time base)."""
    check_columns(path, data, "csv")
    return frame_to_record(read_csv_frame(path), path, data, options, name,
                           data_offset=first_data_line(path))


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
        raise UserError(f"{path}: not a readable CSV ({one_line(exc)})") from None
    if df.height == 0:
        raise UserError(f"{path}: no data rows after the header")
    return df


def first_data_line(path: Path) -> int:
    """1-based line number of the first data row of a CSV (after comments and header)."""
    with open(path, encoding="utf-8", errors="replace") as fh:
        for i, line in enumerate(fh, start=1):
            if line.strip() and not line.lstrip().startswith("#"):
                return i + 1  # the header is this line
    return 2


FORMAT = Format("csv", (".csv",), CsvOptions, load_csv)
