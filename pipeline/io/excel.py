"""Excel workbooks (``.xlsx``), read by polars' Excel reader (the calamine engine,
``fastexcel``).

One sheet is one table: ``sheet`` names it (or gives its 0-based position; default the
first). Whether its first row is a header is detected as for text (:mod:`.sniff`) unless
``header`` says; numbers and date-time cells keep their types.

Keys (``data:``, beside the common ones): ``sheet``, ``header``, ``columns`` (names for a
header-less sheet), and the time and quirk keys of every table
(:class:`~pipeline.io.table.TableOptions`).
"""

from __future__ import annotations

from pathlib import Path

import polars as pl

from ..errors import UserError
from ..record import Record
from .base import DataSection, Format, Places
from .sniff import has_header
from .table import HeaderOptions, Table, TableOptions, column_names, one_line, table_to_record


class XlsxOptions(TableOptions, HeaderOptions):
    """The keys of a workbook: the sheet, the header, the time base, the quirk policies."""

    sheet: str | int | None = None


def load_xlsx(path: Path, data: DataSection, options: XlsxOptions, name: str) -> Record:
    """One sheet of a workbook as a :class:`Record`."""
    return table_to_record(read_xlsx_table(path, options), data, options, name)


def read_xlsx_table(path: Path, options: XlsxOptions) -> Table:
    """The sheet as a :class:`Table` (typed columns)."""
    import fastexcel

    try:
        book = fastexcel.read_excel(str(path))
        sheet = _sheet(book.sheet_names, options.sheet, path)
        first = book.load_sheet(sheet, header_row=None, n_rows=1, dtypes="string").to_polars()
        fields = ["" if v is None else str(v) for v in first.row(0)] if first.height else []
        where = f"{path}: sheet {sheet!r} row 1"
        header = options.header if options.header is not None else has_header(fields, where)
        frame = pl.read_excel(path, sheet_name=sheet, engine="calamine", has_header=False,
                              read_options={"skip_rows": int(header),
                                            "schema_sample_rows": None})
    except fastexcel.FastExcelError as exc:
        raise UserError(f"{path}: not a readable workbook ({one_line(exc)}); expected an "
                        ".xlsx file") from None
    if frame.height == 0:
        raise UserError(f"{path}: sheet {sheet!r} has no data rows; expected a table")
    names = column_names((fields + [""] * frame.width)[:frame.width] if header else None,
                         frame.width,
                         options.columns, where)
    frame = frame.rename({c: str(i) for i, c in enumerate(frame.columns)})
    places = Places(path, range(1 + header, frame.height + 1 + header), word="row",
                    prefix=f"sheet {sheet!r} ")
    return Table(frame, names, places)


def _sheet(sheets: list[str], wanted: str | int | None, path: Path) -> str:
    """The sheet's name: ``wanted`` by name or 0-based position, default the first."""
    listing = ", ".join(repr(s) for s in sheets)
    if wanted is None:
        if not sheets:
            raise UserError(f"{path}: the workbook has no sheets; expected a table")
        return sheets[0]
    if wanted in sheets:
        return str(wanted)
    if isinstance(wanted, int) or str(wanted).isdigit():
        if int(wanted) < len(sheets):
            return sheets[int(wanted)]
    raise UserError(f"{path}: no sheet {wanted!r}; the sheets are {listing}")


FORMAT = Format("xlsx", (".xlsx",), XlsxOptions, load_xlsx)
