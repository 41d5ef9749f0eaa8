"""Delimited text logs (``.csv``, ``.tsv``, ``.txt``): the ``csv`` format.

The delimiter (comma, semicolon, tab or whitespace), the decimal mark and whether the
first line is a header are detected (:mod:`.sniff`), unless ``delimiter``, ``decimal`` or
``header`` say; lines starting with ``#`` and blank lines are skipped; the text is UTF-8
(with or without BOM), UTF-16 with a BOM, or else Latin-1.

Keys (``data:``, beside the common ones): ``delimiter``, ``decimal``, ``header``,
``columns`` (names for a header-less file), ``trailing_lines`` (``error``, or ``skip``
the lines after the data that are not data rows, with a note), and the time and quirk
keys of every table (:class:`~pipeline.io.table.TableOptions`).

The lines are split by the standard ``csv`` module rather than ``polars.read_csv``:
polars fills a short row with nulls without a word and names no line for a long one,
while every error here names the file line. polars then parses the numbers and the
date-times of the columns.
"""

from __future__ import annotations

import codecs
from pathlib import Path
from typing import Annotated, Literal

import polars as pl
from pydantic import BeforeValidator

from ..errors import UserError
from ..record import Record
from .base import DataSection, Format, Places, Strict
from .sniff import (
    DELIMITER_ALIASES,
    DELIMITERS,
    has_header,
    is_value,
    sniff_decimal,
    sniff_delimiter,
    split,
)
from .table import HeaderOptions, Table, TableOptions, column_names, table_to_record

#: ``comma``, ``semicolon``, ``tab``, ``whitespace`` (or the character: ``";"``)
Delimiter = Annotated[Literal[tuple(DELIMITERS)], BeforeValidator(
    lambda v: DELIMITER_ALIASES.get(v, v) if isinstance(v, str) else v)]


class TrailingOption(Strict):
    """``trailing_lines``: lines after the data that are not data rows are an ``error``,
    or ``skip``ped with a note."""

    trailing_lines: Literal["error", "skip"] = "error"


class TextOptions(TableOptions, HeaderOptions, TrailingOption):
    """The keys of a delimited text file (see the module docstring)."""

    delimiter: Delimiter | None = None
    decimal: Literal[".", ","] | None = None


def load_text(path: Path, data: DataSection, options: TextOptions, name: str) -> Record:
    """One delimited text log as a :class:`Record`."""
    return table_to_record(read_text_table(path, options), data, options, name)


def read_text_table(path: Path, options: TextOptions) -> Table:
    """The file's rows as a :class:`Table` of text columns (numbers parsed later)."""
    content = [(n, line) for n, line in enumerate(_lines(path), start=1)
               if line.strip() and not line.lstrip().startswith("#")]
    if not content:
        raise UserError(f"{path}: the file is empty; expected a table of numbers")
    delimiter = options.delimiter or sniff_delimiter([line for _, line in content], str(path))
    rows = [split(line, delimiter) for _, line in content]
    numbers = [n for n, _ in content]
    header = options.header
    if header is None:
        header = has_header(rows[0], f"{path}: line {numbers[0]}")
    body, lines = (rows[1:], numbers[1:]) if header else (rows, numbers)
    body, lines, notes = _trailing(body, lines, len(rows[0]), numbers[0], options, path)
    if not body:
        raise UserError(f"{path}: no data rows after the header")
    names = column_names(rows[0] if header else None, len(rows[0]), options.columns,
                         f"{path}: line {numbers[0]}")
    decimal = options.decimal or sniff_decimal(body, delimiter)
    frame = pl.DataFrame([pl.Series(str(i), col, dtype=pl.String)
                          for i, col in enumerate(zip(*body, strict=True))])
    if decimal == ",":
        frame = frame.with_columns(pl.all().str.replace_all(",", ".", literal=True))
    return Table(frame, names, Places(path, lines), notes=tuple(notes))


def _lines(path: Path) -> list[str]:
    """The file's text lines; a binary file is an error."""
    try:
        raw = path.read_bytes()
    except OSError as exc:
        raise UserError(f"{path}: cannot read the file ({exc.strerror or exc})") from None
    if raw.startswith((codecs.BOM_UTF16_LE, codecs.BOM_UTF16_BE)):
        return raw.decode("utf-16", errors="replace").splitlines()
    if b"\x00" in raw:
        raise UserError(f"{path}: a binary file, not text; expected a delimited text log "
                        "(or set data.format)")
    try:
        return raw.decode("utf-8-sig").splitlines()
    except UnicodeDecodeError:
        return raw.decode("latin-1").splitlines()


def _trailing(body: list[list[str]], lines: list[int], width: int, first: int,
              options: TextOptions, path: Path) -> tuple[list[list[str]], list[int], list[str]]:
    """The data rows without the lines after them that are not data rows (a footer such
    as ``End of log``): an error, or skipped with a note; a short or long row among the
    data is an error."""
    end = len(body)
    while end > 0 and (len(body[end - 1]) != width or not any(map(is_value, body[end - 1]))):
        end -= 1
    if end < len(body):
        text = " ".join(body[end])[:60]
        if options.trailing_lines == "error":
            raise UserError(f"{path}: line {lines[end]}: {text!r} is not a data row after "
                            f"the data; expected {width} fields of numbers, or set "
                            "trailing_lines: skip")
        notes = [f"trailing_lines: {len(body) - end} line(s) after the data skipped, from "
                 f"line {lines[end]} ({text!r})"]
    else:
        notes = []
    for row, n in zip(body[:end], lines[:end], strict=True):
        if len(row) != width:
            raise UserError(f"{path}: line {n}: {len(row)} fields where line {first} has "
                            f"{width}; expected the same number of fields on every row")
    return body[:end], lines[:end], notes

FORMAT = Format("csv", (".csv", ".tsv", ".txt"), TextOptions, load_text,
                aliases=("tsv", "txt", "text"))
