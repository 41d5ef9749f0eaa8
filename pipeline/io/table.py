"""What the tabular formats share: a :class:`Table` of named columns, naming a column by
name or position, units from headers, and the step to a :class:`~pipeline.record.Record`
through the time base (:mod:`.timebase`) and the quirk policies (:mod:`.quirks`).

Columns
    ``input``, ``output`` and ``time`` name a column by its header name (trimmed; with
    or without the unit, ``Heater 1 (%)`` or ``Heater 1``) or by its 0-based position
    (``2``). A header-less table's columns are named by ``columns``, else by position.
Units
    A header ``name (unit)`` or ``name [unit]`` gives the column's unit; ``units`` in the
    config wins, and a unit taken from a header is noted.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import polars as pl
from pydantic import Field

from ..errors import UserError
from ..record import Record, make_record
from ..suggest import did_you_mean
from .base import DataSection, Places, Strict
from .quirks import QuirkOptions, Rows, check_order, fill_gaps, merge_duplicates, unwrap_output
from .timebase import TimeOptions, display_unit, time_base

_UNIT = re.compile(r"(.*?)\s*(?:\(([^()]*)\)|\[([^\[\]]*)\])")
_INDEX = re.compile(r"\d+(?:\s*,\s*\d+)*")


class ColumnsOption(Strict):
    """``columns``: the names of a header-less table's columns, in order."""

    columns: list[str] | None = Field(None, min_length=1)


class HeaderOptions(ColumnsOption):
    """``header``: whether the first row names the columns (default: detected)."""

    header: bool | None = None


class TableOptions(TimeOptions, QuirkOptions):
    """The keys every tabular format takes: the time base and the quirk policies."""


@dataclass(frozen=True)
class Table:
    """A file's columns (``frame``'s i-th column is ``names[i]``) and where each row is.

    ``noun`` is what a column is called in this format's messages (``column``,
    ``variable``); ``left_out`` names columns that are in the file but not in the table,
    with the reason (a .mat variable of another length); ``notes`` are the reader's.
    A reader that read only some columns (the ones a ``data:`` section names) says which:
    ``frame``'s k-th column is then the file's column ``positions[k]``.
    """

    frame: pl.DataFrame
    names: tuple[str, ...]
    places: Places
    noun: str = "column"
    left_out: dict[str, str] | None = None
    notes: tuple[str, ...] = ()
    positions: tuple[int, ...] | None = None

    @property
    def path(self) -> Path:
        return self.places.path

    def column(self, i: int) -> pl.Series:
        """The file's column ``i``."""
        return self.frame.to_series(i if self.positions is None else self.positions.index(i))


def split_unit(name: str) -> tuple[str, str | None]:
    """``"T [°C]"`` -> ``("T", "°C")``; a name without a unit -> ``(name, None)``, and so
    is an index (``result[2]``, a MATLAB matrix's column; ``x(3)``): numbers alone in
    brackets right after the name are a position; ``eta [1]`` (a space) is a unit."""
    text = name.strip()
    m = _UNIT.fullmatch(text)
    if not m or not m.group(1):
        return text, None
    inner = (m.group(2) or m.group(3) or "").strip()
    if _INDEX.fullmatch(inner) and not text[len(m.group(1))].isspace():
        return text, None  # result[2]: the bracket right after the name
    return m.group(1), (m.group(2) or m.group(3) or "").strip() or None


def column_names(header: list[str] | None, n: int, columns: list[str] | None,
                 where: str) -> tuple[str, ...]:
    """A table's ``n`` names: ``columns`` when given, else the header's fields trimmed (an
    empty one named by its position), else (no header) the positions ``0``, ``1``, ..."""
    if columns is not None:
        if len(columns) != n:
            raise _error(where, f"{n} columns, but {len(columns)} column names were given "
                         f"({', '.join(columns)})")
        return tuple(columns)
    if header is None:
        return tuple(str(i) for i in range(n))
    return tuple(f.strip() or str(i) for i, f in enumerate(header))


def _error(where: str, text: str) -> UserError:
    return UserError(f"{where}: {text}")


def resolve(table: Table, ref: str | int, key: str) -> int:
    """The position of the column ``ref`` names (see the module docstring)."""
    names = table.names
    if isinstance(ref, int) or (ref.strip().isdigit() and ref.strip() not in names):
        i = int(ref)
        if 0 <= i < len(names):
            return i
        raise _error(str(table.path), f"{key} {ref!r}: no {table.noun} at position {i}; the "
                     f"{table.noun}s are 0..{len(names) - 1} ({_listing(table)})")
    ref = ref.strip()
    hits = [i for i, n in enumerate(names) if n == ref] or [
        i for i, n in enumerate(names) if split_unit(n)[0] == ref]
    if len(hits) == 1:
        return hits[0]
    if hits:
        raise _error(str(table.path), f"{key} {ref!r}: {len(hits)} {table.noun}s have that "
                     f"name (positions {', '.join(map(str, hits))}); name one by position")
    reason = (table.left_out or {}).get(ref)
    if reason:
        raise _error(str(table.path), f"{table.noun} {ref!r} {reason}")
    hint = did_you_mean(ref, [*names, *(split_unit(n)[0] for n in names)])
    raise _error(str(table.path), f"no {table.noun} {ref!r}{hint}; the {table.noun}s are "
                 f"{_listing(table)}")


def _listing(table: Table) -> str:
    return ", ".join(repr(n) for n in table.names[:40]) + (
        ", ..." if len(table.names) > 40 else "")


def numbers(table: Table, i: int, label: str) -> np.ndarray:
    """Column ``i`` as float64, NaN where a cell is empty (or NaN); text is an error. An
    infinite value (``inf``, an overflowed reading) is kept: the drop-out policy treats it
    as it treats NaN (:func:`~.quirks.fill_gaps`)."""
    s = table.column(i)
    if s.dtype == pl.Float64 and not s.null_count():
        return s.to_numpy()  # one chunk: a read-only view of polars' buffer, no copy
    if s.dtype == pl.String:
        text = s.str.strip_chars()
        values = text.cast(pl.Float64, strict=False)
        bad = values.is_null() & text.is_not_null() & (text != "")
    elif s.dtype.is_numeric() or s.dtype in (pl.Boolean, pl.Null):
        values = s.cast(pl.Float64)
        bad = pl.repeat(False, s.len(), eager=True)
    elif s.dtype.is_nested():  # a list, array or struct per row: no cast gives one number
        raise _error(str(table.path), f"{table.noun} {label!r} holds {s.dtype} values (a "
                     "list or record per row); expected one number per row: flatten it "
                     "(one column per element) or choose another column")
    else:
        values, bad = s.cast(pl.Float64, strict=False), s.is_not_null()
    out = np.asarray(values.fill_null(np.nan).to_numpy(), dtype=np.float64)
    bad = bad.to_numpy()
    if bad.any():
        k = int(np.argmax(bad))
        raise table.places.error(k, f"{table.noun} {label!r} has {str(s[k])!r}; expected a "
                                 "number")
    return out


def table_to_record(table: Table, data: DataSection, options: TableOptions,
                    name: str) -> Record:
    """The record a ``data:`` section picks from a table: the input, the output and the
    time base, through the quirk policies; every change to the data is noted."""
    where = str(table.path)
    if not isinstance(data.input, str | int) or not isinstance(data.output, str | int):
        raise _error(where, "a table's input and output are column names or positions")
    if options.time is None and options.sample_time is None:
        raise _error(where, "neither a time column nor a sample_time was given")
    i_u, i_y = resolve(table, data.input, "input"), resolve(table, data.output, "output")
    i_t = resolve(table, options.time, "time") if options.time is not None else None
    (u_name, u_unit), (y_name, y_unit) = (split_unit(table.names[i]) for i in (i_u, i_y))
    t_name, t_unit = split_unit(table.names[i_t]) if i_t is not None else ("", None)
    given = data.unit_map()
    unit, unit_from = display_unit(options, given.get("time"), t_unit, where)
    base = time_base(None if i_t is None else table.column(i_t), table.frame.height,
                     options, unit, t_name, table.places)
    rows = Rows(base.t, numbers(table, i_u, u_name), numbers(table, i_y, y_name))
    hint = "; if they are local time, set time_zone" if base.as_utc else ""
    dt = check_order(rows, options, table.places, hint)
    rows, merged = (rows, []) if dt is not None else merge_duplicates(rows, options,
                                                                      table.places)
    checked = rows
    rows, filled = fill_gaps(rows, options, (u_name, y_name), table.places)
    rows, unwrapped = unwrap_output(rows, options, y_name)
    if rows.t is not checked.t:
        dt = None  # rows were merged or dropped: the intervals are computed again
    units, from_header = _units(given, unit, unit_from, {"input": u_unit, "output": y_unit})
    notes = [*table.notes, *base.notes, *merged, *filled, *unwrapped, *from_header]
    return make_record(rows.t, rows.u, rows.y, name=name, source=where, units=units,
                       initial_input=data.initial_input, input_name=u_name,
                       output_name=y_name, notes=tuple(notes), start=base.start, copy=False,
                       intervals=dt)


def _units(given: dict[str, str], unit: str, unit_from: str | None,
           header: dict[str, str | None]) -> tuple[dict[str, str], list[str]]:
    """The record's units (the config's, the time unit when someone stated it, then the
    headers') and the note naming those a header gave."""
    units = {**given, **({"time": unit} if unit_from else {})}
    taken = {k: v for k, v in header.items() if v and k not in units}
    shown = {**({"time": unit + (" (converted to seconds)" if unit != "s" else "")}
                if unit_from == "header" else {}), **taken}
    note = ["units from the header: " + ", ".join(f"{k} {v}" for k, v in shown.items())]
    return {**units, **taken}, note if shown else []


def one_line(exc: Exception) -> str:
    """The first line of a library's error message (its type when it has none)."""
    text = str(exc).strip()
    return text.splitlines()[0] if text else type(exc).__name__
