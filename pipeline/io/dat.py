"""DaISy ``.dat`` tables: whitespace-separated numbers without a header.

Read by the delimited-text reader (:mod:`.delimited`) with the layout fixed: whitespace,
a decimal point, no header, ``#`` comments. The columns are named by ``columns`` (from the
config or the dataset registry; default ``time u y``, the DaISy layout, for a
three-column file) or by position.

Keys (``data:``, beside the common ones): ``columns``, ``skip_rows`` and ``trailing_lines``
(as for text),
and the time and quirk keys of every table (:class:`~pipeline.io.table.TableOptions`).
"""

from __future__ import annotations

from pathlib import Path

from ..record import Record
from .base import DataSection, Format
from .delimited import LeadingOption, TextOptions, TrailingOption, read_text_table
from .table import ColumnsOption, TableOptions, table_to_record

#: The DaISy layout, when ``columns`` is not given.
DAISY_COLUMNS = ["time", "u", "y"]


class DatOptions(TableOptions, ColumnsOption, LeadingOption, TrailingOption):
    """The keys of a ``.dat`` file: the column names, the time base, the quirk policies,
    ``skip_rows``, ``trailing_lines``."""


def load_dat(path: Path, data: DataSection, options: DatOptions, name: str) -> Record:
    """One ``.dat`` table as a :class:`Record`, its columns named by ``options.columns``."""
    text = TextOptions(delimiter="whitespace", decimal=".", header=False,
                       columns=options.columns or _default_columns(path, options.skip_rows),
                       skip_rows=options.skip_rows, trailing_lines=options.trailing_lines)
    return table_to_record(read_text_table(path, text), data, options, name)


def _default_columns(path: Path, skip_rows: int) -> list[str] | None:
    """DaISy's ``time u y`` for a three-column file; None (columns by position) for any
    other width (DaISy's own files have up to nine columns)."""
    from .delimited import text_lines

    for n, line in enumerate(text_lines(path), start=1):
        if n > skip_rows and line.strip() and not line.lstrip().startswith("#"):
            return DAISY_COLUMNS if len(line.split()) == 3 else None
    return DAISY_COLUMNS


FORMAT = Format("dat", (".dat",), DatOptions, load_dat)
