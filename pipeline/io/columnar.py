"""Columnar files: Parquet (``.parquet``) and Arrow IPC / Feather v2 (``.feather``,
``.arrow``), read by polars.

Which of the two a file is comes from its first bytes (``PAR1`` or ``ARROW1``), not its
name. The name is taken literally (``glob=False``: ``run[1].parquet`` is that file, not
``run1.parquet``, issue 13), and only the columns the ``data:`` section names are read
(issue 14). The columns are the file's, with their types (numbers, date-times with or without
a zone); a column name ``name (unit)`` or ``name [unit]`` gives a unit as a header does.

Keys (``data:``, beside the common ones): the time and quirk keys of every table
(:class:`~pipeline.io.table.TableOptions`).
"""

from __future__ import annotations

from pathlib import Path

import polars as pl
import polars.selectors as cs
from polars.exceptions import PanicException

from ..errors import UserError
from ..record import Record
from .base import DataSection, Format, Places
from .table import Table, TableOptions, one_line, resolve, table_to_record


class ColumnarOptions(TableOptions):
    """The keys of a Parquet or Arrow file: the time base and the quirk policies."""


def load_columnar(path: Path, data: DataSection, options: ColumnarOptions,
                  name: str) -> Record:
    """One Parquet or Arrow IPC file as a :class:`Record`."""
    return table_to_record(read_columnar_table(path, data, options), data, options, name)


def read_columnar_table(path: Path, data: DataSection | None = None,
                        options: ColumnarOptions | None = None) -> Table:
    """The file's columns as a :class:`Table`: those ``data`` and ``options`` name when
    they name columns that exist (else all, and the record's step says what is wrong)."""
    try:
        with open(path, "rb") as fh:
            magic = fh.read(6)
        if magic.startswith(b"PAR1"):
            lazy = pl.scan_parquet(path, glob=False)
        elif magic == b"ARROW1":
            lazy = pl.scan_ipc(path, glob=False)
        else:
            raise UserError(f"{path}: neither Parquet nor Arrow IPC (it starts {magic!r}); "
                            "expected a .parquet, .feather (v2) or .arrow file")
        columns = lazy.collect_schema().names()
        names = tuple(c.strip() for c in columns)
        wanted = _wanted(Table(pl.DataFrame(), names, Places(path, ())), data, options)
        frame = lazy.select(pl.nth(*wanted)).collect() if wanted else lazy.collect()
    except (pl.exceptions.PolarsError, OSError, PanicException) as exc:
        # a panic of polars' reader (a damaged page it does not check) is a BaseException:
        # caught by name here, it is the file's fault, one line
        raise UserError(f"{path}: not a readable Parquet or Arrow file ({one_line(exc)})"
                        ) from None
    if frame.height == 0:
        raise UserError(f"{path}: no rows; expected a table of samples")
    # dictionary-encoded text (Categorical, Enum) is read as the text it holds: numbers
    # stored that way are numbers, as in a CSV (polars cannot cast them to floats)
    frame = frame.with_columns(cs.categorical().cast(pl.String), cs.enum().cast(pl.String))
    frame = frame.rename({c: str(i) for i, c in enumerate(frame.columns)})
    return Table(frame, names, Places(path, range(1, frame.height + 1), word="row"),
                 positions=tuple(wanted) if wanted else None)


def _wanted(probe: Table, data: DataSection | None,
            options: ColumnarOptions | None) -> list[int] | None:
    """The positions of the time, input and output columns; None when one is not found."""
    if data is None or options is None:
        return None
    refs = [(data.input, "input"), (data.output, "output")] + (
        [(options.time, "time")] if options.time is not None else [])
    if not all(isinstance(ref, str | int) for ref, _ in refs):
        return None
    try:
        return sorted({resolve(probe, ref, key) for ref, key in refs})
    except UserError:
        return None


FORMAT = Format("parquet", (".parquet", ".feather", ".arrow"), ColumnarOptions,
                load_columnar, aliases=("feather", "arrow"))
