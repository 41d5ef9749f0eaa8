"""Excel workbooks (``.xlsx``), read by polars' Excel reader (the calamine engine,
``fastexcel``).

One sheet is one table: ``sheet`` names it (or gives its 0-based position; default the
first). Whether its first row is a header is detected as for text (:mod:`.sniff`) unless
``header`` says; numbers and date-time cells keep their types.

Keys (``data:``, beside the common ones): ``sheet``, ``header``, ``columns`` (names for a
header-less sheet), and the time and quirk keys of every table
(:class:`~pipeline.io.table.TableOptions`).

A formula cell is read as the value a spreadsheet program last calculated for it (the
workbook stores it beside the formula). A workbook written by a library (xlsxwriter,
openpyxl) stores a placeholder, 0, and asks to be recalculated when opened
(``fullCalcOnLoad``); a formula may also have no stored value at all. Either is refused
with the first such cell named (:func:`uncalculated_formula`): read as numbers they would
be silent zeros.
"""

from __future__ import annotations

import re
import zipfile
from pathlib import Path, PurePosixPath
from xml.etree import ElementTree

import polars as pl

from .. import memory
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

    _refuse_oversized(path)
    try:
        book = fastexcel.read_excel(str(path))
        sheet = _sheet(book.sheet_names, options.sheet, path)
        _refuse_uncalculated(path, sheet)
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
    except pl.exceptions.NoDataError:
        others = [s for s in book.sheet_names if s != sheet]
        raise UserError(f"{path}: sheet {sheet!r} is empty; expected a table"
                        + (f" (the other sheets: {', '.join(map(repr, others))}; choose one "
                           "with data.sheet or --sheet)" if others else "")) from None
    if frame.height == 0:
        raise UserError(f"{path}: sheet {sheet!r} has no data rows; expected a table")
    names = column_names((fields + [""] * frame.width)[:frame.width] if header else None,
                         frame.width,
                         options.columns, where)
    frame = frame.rename({c: str(i) for i, c in enumerate(frame.columns)})
    places = Places(path, range(1 + header, frame.height + 1 + header), word="row",
                    prefix=f"sheet {sheet!r} ")
    return Table(frame, names, places)


#: A workbook part that expands more than this many times, to more than
#: :data:`BOMB_SIZE`, is refused: sheets of numbers compress 5-10 times (300,000 rows:
#: random values 4.9x, constant ones 9.6x), a zip bomb 300-1000 times (a 1.7 MB workbook
#: whose sheet expands to 500 MB aborted the reader under a 2 GB address-space limit).
BOMB_RATIO = 100
BOMB_SIZE = 64 << 20
#: Memory a read takes per byte of the workbook's XML, with a margin: the reader peaked at
#: 867 MB for a 500 MB sheet (8.4 M rows), 150 MB of it the imports.
READ_FACTOR = 2.0


def _refuse_oversized(path: Path) -> None:
    """A :class:`UserError` for a workbook that expands like a zip bomb, or whose XML needs
    more memory to read than the process has (:func:`pipeline.memory.available`): the
    reader (Rust) aborts the whole process on a failed allocation, which no exception
    handler sees. The sizes are those the package's directory declares: a crafted file
    can understate them, which this check does not see. An unreadable package is left to
    the reader, which says so."""
    try:
        with zipfile.ZipFile(path) as z:
            parts = z.infolist()
    except (OSError, zipfile.BadZipFile):
        return
    for p in parts:
        if p.file_size > BOMB_SIZE and p.file_size > BOMB_RATIO * max(p.compress_size, 1):
            raise UserError(
                f"{path}: its part {p.filename!r} expands from {_mb(p.compress_size)} to "
                f"{_mb(p.file_size)} ({p.file_size / max(p.compress_size, 1):.0f} times, where "
                "a sheet of numbers compresses 5 to 10 times): a zip bomb or a damaged "
                "workbook, not read")
    # what the reader holds: one sheet (the largest, not knowing yet which is read) and the
    # shared strings; other parts (styles, media) are not read into cells
    sheets = [p.file_size for p in parts if p.filename.startswith("xl/worksheets/")]
    xml = max(sheets, default=0) + sum(p.file_size for p in parts
                                       if p.filename == "xl/sharedStrings.xml")
    free = memory.available()
    if free is not None and READ_FACTOR * xml > free:
        raise UserError(f"{path}: reading it needs about {_mb(READ_FACTOR * xml)} of memory "
                        f"({_mb(xml)} of XML) and {_mb(free)} is available; export the "
                        "sheet as CSV (read in constant memory) or run with more memory")


def _mb(n: float) -> str:
    return f"{n / 2**20:.1f} MB" if n < 2**30 else f"{n / 2**30:.1f} GB"


def _refuse_uncalculated(path: Path, sheet: str) -> None:
    """A :class:`UserError` naming the first formula cell without a calculated value."""
    cell = uncalculated_formula(path, sheet)
    if cell is not None:
        raise UserError(f"{path}: sheet {sheet!r} cell {cell} is a formula whose value was "
                        "never calculated (the workbook was written by a program that left "
                        "it to a spreadsheet; formulas in any column count); expected stored "
                        "values: open and save the workbook in a spreadsheet program, or "
                        "export the sheet as CSV")


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


#: A formula element in a sheet's XML, namespace prefix or not: ``<f>``, ``<f t=...>``,
#: ``<x:f/>``. Searched in the raw bytes first (C speed): most sheets have none.
_FORMULA = re.compile(rb"<(?:[A-Za-z_][\w.-]*:)?f[\s>/]")
_MAIN = "{http://schemas.openxmlformats.org/spreadsheetml/2006/main}"
_REL = "{http://schemas.openxmlformats.org/officeDocument/2006/relationships}"
_PKG_REL = "{http://schemas.openxmlformats.org/package/2006/relationships}"


def uncalculated_formula(path: Path, sheet: str) -> str | None:
    """The first cell of ``sheet`` (its reference, e.g. ``"C2"``) whose formula has no
    calculated value: no stored value (``<f>`` without ``<v>``), or any formula when the
    workbook asks to be recalculated on opening (``<calcPr fullCalcOnLoad="1">``: its
    stored values are the writing library's placeholders; ECMA-376 Part 1, sec. 18.2.2
    and 18.3.1.4). Any formula in the sheet counts, in a column the record uses or not.
    None when every formula has a value a spreadsheet calculated, or the sheet has none.
    The sheet is streamed (:data:`CHUNK` bytes at a time), never held whole; an
    unreadable package is left to the reader, which says so."""
    try:
        with zipfile.ZipFile(path) as z:
            book = z.read("xl/workbook.xml")
            part = _sheet_part(z, book, sheet)
            if not part or not _has_formula(z, part):
                return None
            calc = ElementTree.fromstring(book).find(f"{_MAIN}calcPr")
            recalc = calc is not None and calc.get("fullCalcOnLoad") in ("1", "true")
            with z.open(part) as stream:
                for _, el in ElementTree.iterparse(stream, events=("end",)):
                    if el.tag == f"{_MAIN}c":
                        if el.find(f"{_MAIN}f") is not None and (
                                recalc or el.find(f"{_MAIN}v") is None):
                            return el.get("r") or "?"
                        el.clear()
    except (OSError, KeyError, zipfile.BadZipFile, ElementTree.ParseError):
        return None
    return None


#: Bytes of a sheet's XML searched at a time for a formula element.
CHUNK = 1 << 20


def _has_formula(z: zipfile.ZipFile, part: str) -> bool:
    """Whether the sheet's XML holds a formula element, searched chunk by chunk (a tag cut
    between two chunks is found in the overlap kept from the first)."""
    tail = b""
    with z.open(part) as stream:
        while chunk := stream.read(CHUNK):
            if _FORMULA.search(tail + chunk):
                return True
            tail = chunk[-64:]
    return False


def _sheet_part(z: zipfile.ZipFile, book: bytes, sheet: str) -> str | None:
    """The package part (``xl/worksheets/sheet1.xml``) of the sheet named ``sheet``."""
    rid = next((s.get(f"{_REL}id") for s in ElementTree.fromstring(book).iter(f"{_MAIN}sheet")
                if s.get("name") == sheet), None)
    rels = ElementTree.fromstring(z.read("xl/_rels/workbook.xml.rels"))
    target = next((r.get("Target") for r in rels.iter(f"{_PKG_REL}Relationship")
                   if r.get("Id") == rid), None)
    if not target:
        return None
    if target.startswith("/"):
        return target.lstrip("/")
    return str(PurePosixPath("xl") / target)


FORMAT = Format("xlsx", (".xlsx",), XlsxOptions, load_xlsx)
