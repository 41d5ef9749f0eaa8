"""Columnar files: Parquet (``.parquet``) and Arrow IPC / Feather v2 (``.feather``,
``.arrow``), read by polars.

Which of the two a file is comes from its first bytes (``PAR1`` or ``ARROW1``), not its
name. The columns are the file's, with their types (numbers, date-times with or without
a zone); a column name ``name (unit)`` or ``name [unit]`` gives a unit as a header does.

Keys (``data:``, beside the common ones): the time and quirk keys of every table
(:class:`~pipeline.io.table.TableOptions`).
"""

from __future__ import annotations

from pathlib import Path

import polars as pl

from ..errors import UserError
from ..record import Record
from .base import DataSection, Format, Places
from .table import Table, TableOptions, one_line, table_to_record


class ColumnarOptions(TableOptions):
    """The keys of a Parquet or Arrow file: the time base and the quirk policies."""


def load_columnar(path: Path, data: DataSection, options: ColumnarOptions,
                  name: str) -> Record:
    """One Parquet or Arrow IPC file as a :class:`Record`."""
    return table_to_record(read_columnar_table(path), data, options, name)


def read_columnar_table(path: Path) -> Table:
    """The file's columns as a :class:`Table`."""
    try:
        with open(path, "rb") as fh:
            magic = fh.read(6)
        if magic.startswith(b"PAR1"):
            frame = pl.read_parquet(path)
        elif magic == b"ARROW1":
            frame = pl.read_ipc(path)
        else:
            raise UserError(f"{path}: neither Parquet nor Arrow IPC (it starts {magic!r}); "
                            "expected a .parquet, .feather (v2) or .arrow file")
    except (pl.exceptions.PolarsError, OSError) as exc:
        raise UserError(f"{path}: not a readable Parquet or Arrow file ({one_line(exc)})"
                        ) from None
    if frame.height == 0:
        raise UserError(f"{path}: no rows; expected a table of samples")
    names = tuple(c.strip() for c in frame.columns)
    frame = frame.rename({c: str(i) for i, c in enumerate(frame.columns)})
    return Table(frame, names, Places(path, range(1, frame.height + 1), word="row"))


FORMAT = Format("parquet", (".parquet", ".feather", ".arrow"), ColumnarOptions,
                load_columnar, aliases=("feather", "arrow"))
