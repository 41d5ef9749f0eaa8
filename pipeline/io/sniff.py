"""What a delimited text or a sheet does not say: its delimiter, decimal mark and header.

Hand-written, and kept small, because the libraries guess differently: ``csv.Sniffer``
picks the most regular character, which in a decimal-comma file (``0,5;1,5``) is the comma
itself, and polars takes a delimiter and a header as given. The rules:

- **delimiter**: tab, semicolon, comma (in that order) if splitting by it gives the same
  number of fields (at least two) on the first line and on most of the first lines; a
  comma is not taken when its fields hold numbers separated by spaces (``0.0 1,5 2,5``
  is whitespace with decimal commas); else runs of whitespace, if they split the lines
  alike.
- **decimal mark**: a comma when the delimiter is not a comma and the numbers of the
  first data lines are written ``1,5`` and never ``1.5``. Thousands separators are not
  understood.
- **header**: the first line is a header if all its non-empty fields are names (neither
  numbers nor date-times), data if none is; a line that mixes both is ambiguous and an
  error asking for ``header: true/false``.
"""

from __future__ import annotations

import csv
import re
from collections import Counter

from ..errors import UserError

#: How many lines the guesses look at.
SAMPLE = 50

#: Delimiter names (the ``delimiter`` key's values) and characters, in the order tried.
DELIMITERS: dict[str, str | None] = {"tab": "\t", "semicolon": ";", "comma": ",",
                                     "whitespace": None}

#: Other spellings a user may give for a delimiter (``--delimiter ";"``).
DELIMITER_ALIASES: dict[str, str] = {"\t": "tab", "\\t": "tab", ";": "semicolon",
                                     ",": "comma", " ": "whitespace", "space": "whitespace"}

NUMBER = re.compile(r"[+-]?(\d+([.,]\d*)?|[.,]\d+)([eE][+-]?\d+)?|[+-]?(nan|inf(inity)?)",
                    re.IGNORECASE)
DATETIME = re.compile(
    r"\d{1,4}[-./]\d{1,2}[-./]\d{1,4}([ T]\d{1,2}:\d{2}(:\d{2}([.,]\d+)?)?)?"
    r"\s*(Z|UTC|[+-]\d{2}(:?\d{2})?)?|\d{1,2}:\d{2}(:\d{2}([.,]\d+)?)?", re.IGNORECASE)


def is_value(field: str) -> bool:
    """A number or a date-time (what a data row holds)."""
    field = field.strip()
    return bool(NUMBER.fullmatch(field) or DATETIME.fullmatch(field))


def _spaced_numbers(field: str) -> bool:
    """``"0.0 1"``: numbers separated by blanks (whitespace columns, decimal commas)."""
    parts = field.split()
    return len(parts) > 1 and all(NUMBER.fullmatch(p) for p in parts)


def split(line: str, delimiter: str) -> list[str]:
    """One line's fields (quotes understood; whitespace: runs of blanks)."""
    char = DELIMITERS[delimiter]
    if char is None:
        return line.split()
    if len(line) < _FIELD_LIMIT:
        return next(csv.reader([line], delimiter=char))
    # csv refuses a field over its limit (128 KiB): a huge header line is still a line
    old = csv.field_size_limit(len(line) + 1)
    try:
        return next(csv.reader([line], delimiter=char))
    finally:
        csv.field_size_limit(old)


_FIELD_LIMIT = csv.field_size_limit()


def sniff_delimiter(lines: list[str], where: str) -> str:
    """The delimiter name of the first lines of a file (see the module docstring)."""
    sample = lines[:SAMPLE]
    ragged = None  # (line number, its fields, the header's, delimiter) of a near miss
    for name in DELIMITERS:
        rows = [split(line, name) for line in sample]
        counts = [len(r) for r in rows]
        common, n = Counter(counts).most_common(1)[0]
        columns = common >= 2 and counts[0] == common  # the header has the common width
        alike = n >= 0.8 * len(counts)
        if columns and not alike and ragged is None:
            data = [r for r, c in zip(rows[1:], counts[1:], strict=True) if c == common]
            if len(data) >= 2 and all(is_value(f) for r in data for f in r):
                # a table (its rows of the header's width are numbers) with rows of
                # another width: the first of them is the error, not the delimiter
                k = next(i for i, c in enumerate(counts) if c != common)
                ragged = (k + 1, counts[k], common, name)
        if not (columns and alike):
            continue
        if name == "comma" and any(_spaced_numbers(f) for r in rows[1:] for f in r):
            continue
        return name
    if ragged is not None:  # a short file with a ragged row: name the row
        line, got, want, name = ragged
        raise UserError(f"{where}: line {line} has {got} field{'s' if got != 1 else ''} "
                        f"where the first line has {want} ({name}-separated); expected "
                        f"{want} fields on every line")
    raise UserError(f"{where}: cannot tell how the fields are separated (no tab, semicolon, "
                    "comma or blanks split the first lines alike); expected a delimited "
                    "table, or set delimiter (--delimiter comma|semicolon|tab|whitespace)")


def sniff_decimal(rows: list[list[str]], delimiter: str) -> str:
    """``","`` when the numbers are written with a decimal comma, else ``"."``."""
    if delimiter == "comma":
        return "."
    fields = [f.strip() for r in rows[:SAMPLE] for f in r]
    comma = any(re.fullmatch(r"[+-]?\d*,\d+([eE][+-]?\d+)?", f) for f in fields)
    point = any(re.fullmatch(r"[+-]?\d*\.\d+([eE][+-]?\d+)?", f) for f in fields)
    return "," if comma and not point else "."


def has_header(fields: list[str], where: str) -> bool:
    """Whether a first line (or sheet row) is a header; a mixed line is an error."""
    filled = [f.strip() for f in fields if f.strip()]
    names = [f for f in filled if not is_value(f)]
    if not names:
        return False
    if len(names) == len(filled):
        return True
    shown = ", ".join(repr(f) for f in filled[:6])
    raise UserError(f"{where} mixes names and numbers ({shown}): cannot tell whether it is a "
                    "header; expected a header of names or a row of numbers, or set header: "
                    "true or false (--header / --no-header)")
