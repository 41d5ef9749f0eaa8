"""DaISy ``.dat`` tables: whitespace-separated numbers without a header.

Read by the delimited-text reader (:mod:`.delimited`) with the layout fixed: whitespace,
a decimal point, no header, ``#`` comments. The columns are named by ``columns`` (default
``time u y``, the DaISy layout), from the config or the dataset registry, or by position.

Keys (``data:``, beside the common ones): ``columns``, ``trailing_lines`` (as for text),
and the time and quirk keys of every table (:class:`~pipeline.io.table.TableOptions`).
"""

from __future__ import annotations

from pathlib import Path

from ..record import Record
from .base import DataSection, Format
from .delimited import TextOptions, TrailingOption, read_text_table
from .table import ColumnsOption, TableOptions, table_to_record

#: The DaISy layout, when ``columns`` is not given.
DAISY_COLUMNS = ["time", "u", "y"]


class DatOptions(TableOptions, ColumnsOption, TrailingOption):
    """The keys of a ``.dat`` file: the column names, the time base, the quirk policies,
    ``trailing_lines``."""


def load_dat(path: Path, data: DataSection, options: DatOptions, name: str) -> Record:
    """One ``.dat`` table as a :class:`Record`, its columns named by ``options.columns``."""
    text = TextOptions(delimiter="whitespace", decimal=".", header=False,
                       columns=options.columns or DAISY_COLUMNS,
                       trailing_lines=options.trailing_lines)
    return table_to_record(read_text_table(path, text), data, options, name)


FORMAT = Format("dat", (".dat",), DatOptions, load_dat)
