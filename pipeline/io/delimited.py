"""Delimited text logs (``.csv``, ``.tsv``, ``.txt``): the ``csv`` format.

The delimiter (comma, semicolon, tab or whitespace), the decimal mark and whether the
first line is a header are detected (:mod:`.sniff`), unless ``delimiter``, ``decimal`` or
``header`` say; lines starting with ``#`` and blank lines are skipped; the text is UTF-8
(with or without BOM), UTF-16 with a BOM, or else Latin-1.

Keys (``data:``, beside the common ones): ``delimiter``, ``decimal``, ``header``,
``columns`` (names for a header-less file), ``trailing_lines`` (``error``, or ``skip``
the lines after the data that are not data rows, with a note), and the time and quirk
keys of every table (:class:`~pipeline.io.table.TableOptions`).

The guesses and the header read the first lines with the standard ``csv`` module; the
data lines (comments and blank lines left out, so each row's file line is known) are
parsed by ``polars.read_csv``, and polars then reads the numbers and date-times. A row
with fewer fields has empty cells (drop-outs: ``fill_gaps``); one with more is an error
naming its line.
"""

from __future__ import annotations

import codecs
from pathlib import Path
from typing import Annotated, Literal

import polars as pl
from pydantic import BeforeValidator, Field

from ..errors import UserError
from ..record import Record
from .base import DataSection, Format, Places, Strict
from .plain import read_plain_table
from .sniff import (
    DELIMITER_ALIASES,
    DELIMITERS,
    SAMPLE,
    has_header,
    is_value,
    sniff_decimal,
    sniff_delimiter,
    split,
)
from .table import HeaderOptions, Table, TableOptions, column_names, one_line, table_to_record

#: ``comma``, ``semicolon``, ``tab``, ``whitespace`` (or the character: ``";"``)
Delimiter = Annotated[Literal[tuple(DELIMITERS)], BeforeValidator(
    lambda v: DELIMITER_ALIASES.get(v, v) if isinstance(v, str) else v)]


#: At most this many lines before a table (a logger's banner) are found and skipped.
MAX_BANNER = 20


class LeadingOption(Strict):
    """``skip_rows``: the file's first N lines are not data (a logger's banner, an
    operator's note) and are skipped; without it, up to :data:`MAX_BANNER` such lines are
    found (the first lines from which the fields split alike) and skipped with a note."""

    skip_rows: int = Field(0, ge=0)


class TrailingOption(Strict):
    """``trailing_lines``: lines after the data that are not data rows are an ``error``,
    or ``skip``ped with a note."""

    trailing_lines: Literal["error", "skip"] = "error"


class TextOptions(TableOptions, HeaderOptions, LeadingOption, TrailingOption):
    """The keys of a delimited text file (see the module docstring)."""

    delimiter: Delimiter | None = None
    decimal: Literal[".", ","] | None = None


def load_text(path: Path, data: DataSection, options: TextOptions, name: str) -> Record:
    """One delimited text log as a :class:`Record`: a plain file read directly
    (:mod:`.plain`), any other line by line."""
    table = None if options.skip_rows else read_plain_table(
        path, data, options, delimiter=options.delimiter, decimal=options.decimal,
        header=options.header, columns=options.columns)
    return table_to_record(table or read_text_table(path, options), data, options, name)


def read_text_table(path: Path, options: TextOptions) -> Table:
    """The file's rows as a :class:`Table` of text columns (numbers parsed later)."""
    content = [(n, line) for n, line in enumerate(text_lines(path), start=1)
               if n > options.skip_rows and line.strip() and not line.lstrip().startswith("#")]
    if not content:
        raise UserError(f"{path}: the file is empty; expected a table of numbers")
    delimiter, lead = options.delimiter, []
    if delimiter is None:
        delimiter, k = _sniff_after_banner(content, path)
        if k:
            lead = [f"skipped {k} line(s) before the table that are not data (lines "
                    f"{content[0][0]}-{content[k - 1][0]}); set skip_rows: "
                    f"{content[k - 1][0]} (--skip-rows) to say so"]
            content = content[k:]
    first, top = content[0]
    head = split(top, delimiter)
    header = options.header
    if header is None:
        header = has_header(head, f"{path}: line {first}")
    body, notes = _trailing(content[1:] if header else content, head, first, delimiter,
                            options, path)
    if not body:
        raise UserError(f"{path}: no data rows after the header")
    names = column_names(head if header else None, len(head), options.columns,
                         f"{path}: line {first}")
    frame = _parse(body, delimiter, len(head), first, path)
    decimal = options.decimal or sniff_decimal([split(line, delimiter) for _, line in
                                                body[:SAMPLE]], delimiter)
    if decimal == ",":
        frame = frame.with_columns(pl.all().str.replace_all(",", ".", literal=True))
    return Table(frame, names, Places(path, [n for n, _ in body]), notes=tuple(lead + notes))


def _sniff_after_banner(content: list[tuple[int, str]], path: Path) -> tuple[str, int]:
    """``(delimiter, k)``: the delimiter of the first lines, or, when they do not split
    alike, of the lines after the first ``k`` (at most :data:`MAX_BANNER`: a logger's
    banner before the table); the first lines' error when no ``k`` helps."""
    lines = [line for _, line in content]
    try:
        return sniff_delimiter(lines[:SAMPLE], str(path)), 0
    except UserError as first_error:
        for k in range(1, min(MAX_BANNER, len(lines) - 2) + 1):
            try:
                found = sniff_delimiter(lines[k:k + SAMPLE], str(path))
            except UserError:
                continue
            width = len(split(lines[k], found))
            if abs(len(split(lines[k - 1], found)) - width) <= 1:
                break  # the line before splits almost as the table does: a header of
                # another width (a trailing comma), not a banner; say what was found
            return found, k
        raise first_error from None


def _parse(body: list[tuple[int, str]], delimiter: str, width: int, first: int,
           path: Path) -> pl.DataFrame:
    """The data lines as text columns, parsed by polars. A row with fewer fields has empty
    cells (a drop-out, see fill_gaps); one with more is an error naming its line, and so is
    any whitespace row of another width (a blank field cannot be seen there)."""
    if delimiter == "whitespace":
        parts = [line.split() for _, line in body]
        _check_widths([(n, len(p)) for (n, _), p in zip(body, parts, strict=True)], width,
                      first, path)
        text, sep = "\n".join("\t".join(p) for p in parts), "\t"
    else:
        text, sep = "\n".join(line for _, line in body), DELIMITERS[delimiter]
    try:
        frame = pl.read_csv(text.encode(), separator=sep, has_header=False, infer_schema=False,
                            new_columns=[str(i) for i in range(width)])
    except pl.exceptions.PolarsError as exc:
        _check_widths([(n, len(split(line, delimiter))) for n, line in body], width, first,
                      path)
        raise UserError(f"{path}: not a readable table ({one_line(exc)})") from None
    if frame.shape != (len(body), width):  # e.g. a quoted field across lines
        raise UserError(f"{path}: {frame.height} rows of {frame.width} fields where the file "
                        f"has {len(body)} data lines of {width}; expected one row per line")
    return frame


def _check_widths(counts: list[tuple[int, int]], width: int, first: int, path: Path) -> None:
    """The first row whose number of fields is not ``width`` (that of line ``first``)."""
    for n, k in counts:
        if k != width:
            raise UserError(f"{path}: line {n}: {k} fields where line {first} has {width}; "
                            "expected the same number of fields on every row")


def text_lines(path: Path) -> list[str]:
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


def _trailing(body: list[tuple[int, str]], head: list[str], first: int, delimiter: str,
              options: TextOptions, path: Path) -> tuple[list[tuple[int, str]], list[str]]:
    """The data lines without the lines after them that are not data rows (a footer such
    as ``End of log``: another number of fields, or no number): an error, or skipped with
    a note."""
    end = len(body)
    while end > 0 and not _data_like(split(body[end - 1][1], delimiter), len(head)):
        end -= 1
    if end in (0, len(body)):  # no footer, or no row looks like data (the cells will say)
        return body, []
    n, text = body[end][0], body[end][1].strip()[:60]
    if options.trailing_lines == "error":
        raise UserError(f"{path}: line {n}: {text!r} is not a data row after the data; "
                        f"expected {len(head)} fields of numbers, or set trailing_lines: skip")
    return body[:end], [f"trailing_lines: {len(body) - end} line(s) after the data skipped, "
                        f"from line {n} ({text!r})"]


def _data_like(fields: list[str], width: int) -> bool:
    return len(fields) == width and any(map(is_value, fields))


FORMAT = Format("csv", (".csv", ".tsv", ".txt"), TextOptions, load_text,
                aliases=("tsv", "txt", "text"))
