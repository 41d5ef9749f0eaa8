"""The direct read of a plain delimited log: only the named columns, typed, at polars speed.

Most logs are plain: a header (perhaps after ``#`` comment lines), then one row of
numbers per line, no comments or blank lines among the rows. For such a file the
line-by-line reader of :mod:`.delimited` (which keeps every line's number for its
messages) costs 8 to 9 times a bare ``polars.read_csv`` (issue 14). Here the guesses
(delimiter, header, decimal mark) read the first lines only; then polars reads just the
time, input and output columns (and column 0, to see comment lines) with a declared
Float64 schema, straight from the file (``glob=False``: a name such as ``run[1].csv`` is
that file, issue 13), and the columns become numpy arrays without a copy.

Anything this read cannot vouch for sends the file to the line-by-line reader, which
says what is wrong with the line it is on: a first look at lines that are not plain
(UTF-16, blanks in the numbers, whitespace columns, comment or blank lines among the
first rows), a polars error (text among the numbers, a footer, a row with more fields),
an empty cell (a blank line, unless only at the end, a drop-out, a short row) or a
comment line later in the file. So the result, notes and errors are those of :mod:`.delimited`; only
a quoted field across lines in an unread column shifts the line numbers after it.
"""

from __future__ import annotations

import codecs
from pathlib import Path

import numpy as np
import polars as pl

from ..errors import UserError
from .base import DataSection, Places
from .sniff import NUMBER, SAMPLE, has_header, sniff_decimal, sniff_delimiter, split
from .table import Table, TableOptions, column_names, resolve

#: The first look reads this much of the file, more (up to HEAD_MAX) for a long header.
HEAD = 1 << 16
HEAD_MAX = 1 << 26
#: Line breaks other than ``\n`` / ``\r\n`` that :meth:`str.splitlines` also splits at.
_OTHER_BREAKS = "\x0b\x0c\x1c\x1d\x1e\x85\u2028\u2029"


class NotPlain(Exception):
    """The file is for the line-by-line reader."""


def read_plain_table(path: Path, data: DataSection, options: TableOptions, *,
                     delimiter: str | None, decimal: str | None, header: bool | None,
                     columns: list[str] | None) -> Table | None:
    """The columns ``data`` names as a :class:`Table` (with ``positions``), or None when
    the file is not plain (see the module docstring)."""
    try:
        return _read(path, data, options, delimiter, decimal, header, columns)
    except (NotPlain, UserError, pl.exceptions.PolarsError, OSError, ValueError,
            BufferError):
        return None


def _read(path: Path, data: DataSection, options: TableOptions, delimiter: str | None,
          decimal: str | None, header: bool | None, columns: list[str] | None) -> Table:
    lines, eof = _head(path)
    content = [(n, line) for n, line in enumerate(lines, start=1)
               if line.strip() and not line.lstrip().startswith("#")]
    if len(content) < 2 or (not eof and len(content) < SAMPLE):
        raise NotPlain
    first, top = content[0]
    delimiter = delimiter or sniff_delimiter([line for _, line in content[:SAMPLE]], "")
    if delimiter == "whitespace":
        raise NotPlain
    head = split(top, delimiter)
    if header is None:
        header = has_header(head, "")
    body = content[1:] if header else content
    start = first + int(header)  # the file line of the first data row
    if not body or [n for n, _ in body] != list(range(start, start + len(body))):
        raise NotPlain  # comment or blank lines among the rows
    rows = [split(line, delimiter) for _, line in body[:SAMPLE]]
    decimal = decimal or sniff_decimal(rows, delimiter)
    names = column_names(head if header else None, len(head), columns, "")
    probe = Table(pl.DataFrame(), names, Places(path, ()))
    if not isinstance(data.input, str | int) or not isinstance(data.output, str | int):
        raise NotPlain
    picked = [resolve(probe, data.input, "input"), resolve(probe, data.output, "output")]
    i_t = resolve(probe, options.time, "time") if options.time is not None else None
    wanted = sorted({0, *picked, *([] if i_t is None else [i_t])})
    types = {i: _type(rows, i, i == i_t) if i in picked or i == i_t else pl.String
             for i in wanted}
    how = {"has_header": False, "separator": _CHARS[delimiter], "skip_lines": start - 1,
           "schema": {str(i): types.get(i, pl.String) for i in range(len(head))},
           "decimal_comma": decimal == ",", "infer_schema": False, "glob": False,
           "raise_if_empty": False}
    frame = None
    if all(types[i] == pl.Float64 for i in wanted) and hasattr(pl.LazyFrame,
                                                                "collect_batches"):
        frame = _streamed(path, how, wanted, _rows_estimate(path, lines, start))
    if frame is None:
        frame = pl.read_csv(path, columns=wanted, **how)
    if any(frame.null_count().row(0)):
        frame = _without_trailing_blanks(frame, path)
        if any(frame.null_count().row(0)):
            raise NotPlain  # an empty cell or a short row: the line-by-line reader says which
    _no_comment_rows(frame, types)
    if decimal == "," and i_t is not None and types[i_t] == pl.String:
        frame = frame.with_columns(pl.col(str(i_t)).str.replace_all(",", ".", literal=True))
    return Table(_one_chunk(frame), names, Places(path, range(start, start + frame.height)),
                 positions=tuple(wanted))


_CHARS = {"tab": "\t", "semicolon": ";", "comma": ","}
#: Rows per batch of the streamed read (:func:`_streamed`).
BATCH_ROWS = 1 << 20


def _streamed(path: Path, how: dict, wanted: list[int], n_estimate: int
              ) -> pl.DataFrame | None:
    """The ``wanted`` columns, all numbers, read by polars' streaming engine in batches
    of :data:`BATCH_ROWS` rows and copied straight into numpy arrays (sized from the
    estimate, then resized in place to the rows read: ``realloc``, no copy for arrays
    this large), each then a polars column without a copy; None when a batch has an
    empty cell (the whole-file read says where: trailing blank lines or a drop-out). A
    whole-file read holds the parsed pieces and their contiguous copy at once: at 10 M
    rows it peaked at 2.7-3.0 times the three arrays."""
    names = [str(i) for i in wanted]
    out = [np.empty(max(n_estimate, 1)) for _ in names]
    k = 0
    batches = pl.scan_csv(path, **how).select(names).collect_batches(chunk_size=BATCH_ROWS)
    for batch in batches:
        if any(batch.null_count().row(0)):
            return None
        m = batch.height
        for a, name in zip(out, names, strict=True):
            if k + m > a.size:  # the estimate was short
                a.resize(max(k + m, int(1.5 * a.size)), refcheck=False)
            a[k : k + m] = batch.get_column(name).to_numpy()
        k += m
    for a in out:
        a.resize(k, refcheck=False)  # no view of it exists yet
    return pl.DataFrame([pl.Series(name, a) for name, a in zip(names, out, strict=True)])


def _rows_estimate(path: Path, lines: list[str], start: int) -> int:
    """About how many data rows the file holds: its size after the header over the first
    rows' mean length, with a margin (a short estimate costs a reallocation, a long one
    nothing: the arrays are cut to the rows read)."""
    head = [len(line.encode("utf-8")) + 1 for line in lines[start - 1:]]
    before = sum(len(line.encode("utf-8")) + 1 for line in lines[: start - 1])
    if not head:
        return 1024
    size = path.stat().st_size - before
    return int(1.02 * size / (sum(head) / len(head))) + 1024


def _head(path: Path) -> tuple[list[str], bool]:
    """The first lines of the file (the last, perhaps cut, left out unless at the end of
    the file) and whether they are all of it."""
    size = HEAD
    with open(path, "rb") as fh:
        while True:
            raw = fh.read(size)
            eof = len(raw) < size
            if eof or raw.count(b"\n") > SAMPLE + 2 or size >= HEAD_MAX:
                break
            fh.seek(0)
            size *= 4
    if raw.startswith((codecs.BOM_UTF16_LE, codecs.BOM_UTF16_BE)) or b"\x00" in raw:
        raise NotPlain
    if not eof:
        raw = raw[: raw.rfind(b"\n") + 1]
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError:
        text = raw.decode("latin-1")
    if any(c in text for c in _OTHER_BREAKS) or text.count("\r") != text.count("\r\n"):
        raise NotPlain
    return text.splitlines(), eof


def _type(rows: list[list[str]], i: int, time: bool) -> pl.DataType:
    """Float64 when the first rows hold plain numbers in column ``i``; a time column of
    other text is read as text (date-times); anything else is not plain."""
    cells = [r[i] if i < len(r) else "" for r in rows]
    if all(NUMBER.fullmatch(c) for c in cells):
        return pl.Float64
    if time and all(c and c == c.strip() for c in cells):
        return pl.String
    raise NotPlain  # blanks around numbers, empty cells or text among the first rows


def _without_trailing_blanks(frame: pl.DataFrame, path: Path) -> pl.DataFrame:
    """The rows without blank lines at the end of the file (polars reads them as rows
    without values); a row without any value elsewhere is not plain."""
    empty = pl.all_horizontal(pl.all().is_null())
    blank = frame.select(empty.alias("b")).to_series()
    k = int(blank.sum())
    if not k:
        return frame
    if blank.tail(k).all() and _ends_blank(path, k):
        return frame.head(frame.height - k)
    raise NotPlain


def _ends_blank(path: Path, k: int) -> bool:
    """Whether the last ``k`` lines of the file are blank."""
    with open(path, "rb") as fh:
        fh.seek(0, 2)
        fh.seek(max(fh.tell() - 4096 - 64 * k, 0))
        tail = fh.read().splitlines()
    return len(tail) > k and all(not line.strip() for line in tail[-k:])


def _no_comment_rows(frame: pl.DataFrame, types: dict[int, pl.DataType]) -> None:
    """A comment line among the rows (column 0 starting ``#``): not plain."""
    if types[0] == pl.String and frame.get_column("0").str.strip_chars_start().str \
            .starts_with("#").any():
        raise NotPlain


def _one_chunk(frame: pl.DataFrame) -> pl.DataFrame:
    """Each column in one piece, so that ``to_numpy`` is a view, not a copy; one column at
    a time, so that at most one column is held twice."""
    columns = []
    for name in list(frame.columns):
        series = frame.drop_in_place(name)
        columns.append(series.rechunk() if series.n_chunks() > 1 else series)
        del series
    return pl.DataFrame(columns)

