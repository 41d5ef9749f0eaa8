"""The time base of a tabular log, shared by every tabular format (:class:`TimeOptions`).

- A **numeric** time column is in ``time_unit`` (``s``, ``ms``, ``min``, ``h``; default the
  unit of its header, e.g. ``t [ms]``, else seconds) and is converted to seconds.
- A **date-time** column (ISO-8601 text with or without an offset, another layout with
  ``time_format``, or a spreadsheet's or Parquet file's date-time cells) becomes seconds
  from the first sample. Stamps with an offset are exact instants. Stamps without one are
  wall-clock time in ``time_zone`` (an IANA name, e.g. ``Europe/Berlin``): across the
  autumn change a repeated hour is read as the later one once the clock has gone back,
  and a stamp in the skipped spring hour is an error; without ``time_zone`` they are taken
  as UTC (with a note). The absolute start is kept (``Record.start``, ISO-8601 with offset).
- Without a time column, ``sample_time`` (in ``time_unit``) spaces the rows.
- **Epoch stamps**: numeric times that start far from zero (more than a million steps,
  e.g. Unix time 1.7e9 s at 10 Hz) are made relative to the first, with a note; float64
  holds such a stamp only to about 2e-7 s, so a grid that is regular but for that
  rounding (:func:`regular_despite_rounding`) is put back on its exact steps.
- **An irregular grid** (a historian that stores on change, a crafted 1 ms / 0.9 s grid)
  is kept as it is: it is simulated with one exact zero-order-hold step per distinct
  interval (:mod:`pipeline.simulation.zoh`), at a cost linear in the samples.

The record's ``units["time"]`` is the unit the user reads times in (``time_unit``); the
record itself is always in seconds.
"""

from __future__ import annotations

import zoneinfo
from dataclasses import dataclass
from datetime import datetime
from typing import Annotated, Literal

import numpy as np
import polars as pl
from pydantic import AfterValidator, BeforeValidator, Field, field_validator

from ..errors import UserError
from ..record import TIME_UNITS, time_unit, to_seconds
from .base import Places, Strict


def _unit_spelling(value):
    return (time_unit(value) or value) if isinstance(value, str) else value


def _known_zone(value):
    if value is not None:
        try:
            zoneinfo.ZoneInfo(value)
        except (zoneinfo.ZoneInfoNotFoundError, ValueError):
            raise ValueError(f"unknown time zone {value!r}; expected an IANA name such as "
                             "Europe/Berlin or UTC") from None
    return value


#: ``s``, ``ms``, ``min``, ``h`` (and their spellings: ``sec``, ``hours``, ...)
TimeUnit = Annotated[Literal[tuple(TIME_UNITS)], BeforeValidator(_unit_spelling)]
#: an IANA time zone name, checked against the zone database
TimeZone = Annotated[str, AfterValidator(_known_zone)]


class TimeOptions(Strict):
    """The time keys of the tabular formats: a ``time`` column (a name or a 0-based
    position) or a ``sample_time``; ``time_unit``, ``time_zone``, ``time_format``."""

    time: str | int | None = None
    sample_time: float | None = Field(None, gt=0)
    time_unit: TimeUnit | None = None
    time_zone: TimeZone | None = None
    time_format: str | None = None

    @field_validator("sample_time")
    @classmethod
    def _one_time_base(cls, value, info):
        if value is not None and info.data.get("time") is not None:
            raise ValueError("a sample time and a time column exclude each other; give one")
        return value


@dataclass(frozen=True)
class TimeBase:
    """Seconds per row, the display unit, the absolute start; ``as_utc`` when date-times
    without offset or zone were taken as UTC."""

    t: np.ndarray
    unit: str
    start: str | None = None
    notes: tuple[str, ...] = ()
    as_utc: bool = False


def display_unit(options: TimeOptions, label: str | None, header: str | None,
                 where: str) -> tuple[str, str | None]:
    """The time unit and who stated it: ``time_unit``, else ``units.time``, else the time
    column's header (``t [ms]``), else seconds (stated by nobody: None)."""
    given = time_unit(label) if label else None
    if label and given is None:
        raise UserError(f"{where}: units.time {label!r} is not a time unit; expected "
                        f"{', '.join(TIME_UNITS)} (time_unit converts the time column)")
    if options.time_unit and given and given != options.time_unit:
        raise UserError(f"{where}: units.time {label!r} and time_unit "
                        f"{options.time_unit!r} disagree; give one (time_unit converts)")
    from_header = time_unit(header) if header else None
    for unit, source in ((options.time_unit, "time_unit"), (given, "units"),
                         (from_header, "header")):
        if unit:
            return unit, source
    return "s", None


def time_base(column: pl.Series | None, n: int, options: TimeOptions, unit: str,
              name: str, at: Places) -> TimeBase:
    """The record's time in seconds from a time column (or ``sample_time``); an empty
    time cell is an error."""
    if column is None:
        return TimeBase(to_seconds(np.arange(n) * float(options.sample_time), unit), unit)
    if column.dtype.is_numeric():
        return _numeric(column.cast(pl.Float64), unit, name, at)
    if column.dtype == pl.String:
        text = column.str.strip_chars()
        numbers = text.cast(pl.Float64, strict=False)
        if numbers.is_not_null().any() and not (numbers.is_null() & _filled(text)).any():
            return _numeric(numbers, unit, name, at)
        first = int(_filled(text).arg_max() or 0)
        if numbers[first] is not None:  # numbers, then something else
            bad = int((numbers.is_null() & _filled(text)).arg_max())
            raise at.error(bad, f"time column {name!r} has {text[bad]!r}; expected a number "
                           "like the rows before")
        stamps = _parse(text, options.time_format, name, at)
        offset_start = _iso_start(text[first])
    elif isinstance(column.dtype, pl.Datetime | pl.Date):
        stamps, offset_start = column.cast(pl.Datetime("ns", _zone(column.dtype))), None
    else:
        raise at.error(0, f"time column {name!r} holds {column.dtype} values; expected "
                       "numbers or date-times")
    return _seconds(stamps, options.time_zone, offset_start, unit, name, at)


def _numeric(numbers: pl.Series, unit: str, name: str, at: Places) -> TimeBase:
    if numbers.null_count() or not numbers.is_finite().all():
        _bad_stamp(numbers, name, at)
    t = to_seconds(numbers.to_numpy(), unit)
    return _relative(t, unit, name) if t.size > 1 else TimeBase(t, unit)


def _bad_stamp(numbers: pl.Series, name: str, at: Places) -> None:
    """The first empty, NaN or infinite stamp as an error naming its row."""
    _no_empty(numbers.is_null() | numbers.is_nan(), name, at)
    infinite = numbers.is_infinite()
    if infinite.any():
        i = int(infinite.arg_max())
        raise at.error(i, f"time column {name!r} has {numbers[i]}; expected a finite time "
                       "stamp")


#: Stamps whose first is more than this many median intervals from zero are epoch-like.
EPOCH_STEPS = 1e6


def _relative(t: np.ndarray, unit: str, name: str = "") -> TimeBase:
    """Epoch-like times (see the module docstring) relative to the first, else as read."""
    step = float(np.median(np.diff(t[: 10_000])))  # a long log's first 10 k are enough
    if not step > 0 or abs(t[0]) <= EPOCH_STEPS * step:
        return TimeBase(t, unit)
    t0 = float(t[0])
    notes = [f"time column {name!r} starts at {t0:.10g} s (epoch stamps): times are "
             "relative to the first stamp"]
    regular = regular_despite_rounding(t)
    rel = t - t0 if regular is None else np.arange(t.size) * regular
    if regular is not None:
        notes[0] += (f"; their float64 rounding (up to {np.spacing(abs(t0)):.2g} s) taken "
                     f"out: a regular grid of {regular:.6g} s")
    return TimeBase(rel, unit, notes=tuple(notes))


def regular_despite_rounding(t: np.ndarray) -> float | None:
    """The exact step of times that are a regular grid but for float64's rounding of their
    magnitude (Unix stamps: 1.7e9 s are held to 2.4e-7 s, which a 0.1 s grid's regularity
    test, 1e-6 of the step, does not allow); None when they are not. The step is the
    mean interval (the span over the intervals), which the rounding barely touches."""
    dt = np.diff(t)
    step = (float(t[-1]) - float(t[0])) / (t.size - 1)
    rounding = 4 * float(np.spacing(max(abs(float(t[0])), abs(float(t[-1])))))
    if step > 0 and max(float(dt.max()) - step, step - float(dt.min())) <= (
            1e-6 * step + rounding):
        return step
    return None




def _no_empty(empty: pl.Series, name: str, at: Places) -> None:
    if empty.any():
        i = int(empty.arg_max())
        raise at.error(i, f"time column {name!r} is empty; expected a time stamp")


def _filled(text: pl.Series) -> pl.Series:
    return text.is_not_null() & (text != "")


def _zone(dtype) -> str | None:
    return getattr(dtype, "time_zone", None)


def _parse(text: pl.Series, fmt: str | None, name: str, at: Places) -> pl.Series:
    """Date-time text as polars date-times; the first that does not parse is an error."""
    expected = (f"expected date-times like {fmt!r} (time_format)" if fmt else
                "expected a number or an ISO-8601 date-time such as "
                "2024-10-27T02:30:00+02:00 (or set time_format)")
    try:
        stamps = text.str.to_datetime(format=fmt, strict=False, time_unit="ns")
    except pl.exceptions.PolarsError:
        stamps = pl.Series([None] * text.len(), dtype=pl.Datetime("ns"))
    bad = stamps.is_null() & _filled(text)
    if bad.any():
        i = int(bad.arg_max())
        raise at.error(i, f"time column {name!r} has {text[i]!r}; {expected}")
    return stamps


def _iso_start(text: str) -> str | None:
    """The first stamp's own offset, when it is ISO-8601 text with one."""
    try:
        stamp = datetime.fromisoformat(text)
    except ValueError:
        return None
    return stamp.isoformat() if stamp.tzinfo is not None else None


def _seconds(stamps: pl.Series, zone: str | None, offset_start: str | None, unit: str,
             name: str, at: Places) -> TimeBase:
    notes: list[str] = []
    if _zone(stamps.dtype) is None:
        if zone is None:
            notes.append(f"time column {name!r}: date-times without offset taken as UTC "
                         "(set time_zone if they are local time)")
        stamps = _localize(stamps, zone or "UTC", name, at)
    ns = stamps.dt.epoch("ns")
    _no_empty(ns.is_null(), name, at)
    t = ((ns - ns[0]).cast(pl.Float64) / 1e9).to_numpy()
    first = stamps[0]
    start = (first.astimezone(zoneinfo.ZoneInfo(zone)).isoformat() if zone
             else offset_start or first.isoformat())
    return TimeBase(t, unit, start, tuple(notes), as_utc=zone is None and bool(notes))


def _localize(stamps: pl.Series, zone: str, name: str, at: Places) -> pl.Series:
    """Wall-clock date-times in ``zone`` as instants: an ambiguous stamp (the hour the
    clock repeats in autumn) is the earlier instant until the clock has gone back, the
    later one after; a stamp that does not exist (the hour skipped in spring) is an error."""
    wall = stamps.dt.epoch("ns")
    back = (wall < wall.cum_max().shift(1)).fill_null(False)
    frame = pl.DataFrame({"t": stamps, "fold": back})
    local = frame.select(pl.col("t").dt.replace_time_zone(
        zone, ambiguous=pl.when(pl.col("fold")).then(pl.lit("latest"))
        .otherwise(pl.lit("earliest")), non_existent="null"))["t"]
    lost = local.is_null() & stamps.is_not_null()
    if lost.any():
        i = int(lost.arg_max())
        raise at.error(i, f"time column {name!r} has {stamps[i]}, which does not exist in "
                       f"{zone} (the clock skips it); expected local wall-clock time, or the "
                       "right time_zone")
    return local
