"""The quirks of real logs as explicit policies, shared by the tabular formats
(:class:`QuirkOptions`). Each policy that changes the data adds one note to the record.

- ``duplicates``: rows that repeat a time stamp (a logger writing several rows per stamp)
  are an ``error`` (default), merged into their ``mean``, or only the ``first`` is kept.
- ``fill_gaps: N``: runs of up to N empty input/output cells (logger drop-outs) are
  filled as :mod:`pipeline.io.align` resamples: the input (a command) held from the
  sample before, the output interpolated linearly in time. An infinite value (``inf``,
  an overflowed reading) is a drop-out as an empty cell or ``nan`` is. Default 0: an
  empty cell is an error. A longer run is an error, or with ``long_gaps: keep_longest``
  only the longest stretch between such runs is kept. Empty cells at the very start or end have no
  neighbours to fill from and are dropped with the run.
- ``unwrap: P``: an output that wraps with period P (a position counter, an angle in
  degrees with P = 360) is unwrapped: a jump by more than P/2 between samples is taken as
  a wrap (numpy.unwrap).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np
from pydantic import Field

from .base import Places, Strict


class QuirkOptions(Strict):
    """The policies for repeated stamps and drop-outs (see the module docstring)."""

    duplicates: Literal["error", "mean", "first"] = "error"
    fill_gaps: int = Field(0, ge=0)
    long_gaps: Literal["error", "keep_longest"] = "error"
    unwrap: float | None = Field(None, gt=0)


def unwrap_output(rows: Rows, options: QuirkOptions, name: str) -> tuple[Rows, list[str]]:
    """The output unwrapped with ``options.unwrap``'s period, and its note."""
    if options.unwrap is None:
        return rows, []
    y = np.unwrap(rows.y, period=options.unwrap)
    wraps = int(np.count_nonzero(np.abs(np.diff(y - rows.y)) > 0))
    note = (f"unwrap: output {name!r} unwrapped with period {options.unwrap:g} "
            f"({wraps} wrap(s) taken out)")
    return Rows(rows.t, rows.u, y, rows.index), [note]


@dataclass(frozen=True)
class Rows:
    """Time (s), input and output of the data rows, and each row's index in the file's
    table (for the lines errors and notes name; None: row k is the table's row k, so a
    long log needs no index array until a policy drops rows)."""

    t: np.ndarray
    u: np.ndarray
    y: np.ndarray
    index: np.ndarray | None = None

    def take(self, keep: np.ndarray) -> Rows:
        return Rows(self.t[keep], self.u[keep], self.y[keep], self.indices(keep))

    def indices(self, keep: np.ndarray) -> np.ndarray:
        """The table rows of the rows ``keep`` selects (a mask or positions)."""
        if self.index is not None:
            return self.index[keep]
        return np.flatnonzero(keep) if keep.dtype == bool else np.asarray(keep)

    def row(self, k: int) -> int:
        """The table row of row ``k``."""
        return int(k if self.index is None else self.index[k])


def check_order(rows: Rows, options: QuirkOptions, at: Places,
                hint: str = "") -> np.ndarray | None:
    """Time going back is an error; a repeated stamp is one unless ``duplicates`` merges.
    The intervals ``np.diff(rows.t)`` when the time is strictly increasing (nothing to
    merge; the later checks reuse them), else None."""
    dt = np.diff(rows.t)
    if not dt.size or dt.min() > 0:  # one pass over a long log in the usual case
        return dt
    back = np.flatnonzero(dt < 0)
    same = np.flatnonzero(dt == 0) if options.duplicates == "error" else np.array([], int)
    k = min([*back[:1], *same[:1]], default=None)
    if k is None:
        return None
    a, b = rows.t[k], rows.t[k + 1]
    if dt[k] == 0:
        raise at.error(rows.row(k + 1), f"the time stamp {a:.6g} s repeats; expected "
                       "increasing time stamps, or set duplicates: mean (or first) to merge "
                       "the rows of a stamp")
    raise at.error(rows.row(k + 1), f"time is not strictly increasing ({a:.6g} s then "
                   f"{b:.6g} s); expected increasing time stamps{hint}")


def merge_duplicates(rows: Rows, options: QuirkOptions,
                     at: Places) -> tuple[Rows, list[str]]:
    """Rows of one stamp merged by ``options.duplicates`` (the time already ordered)."""
    new = np.diff(rows.t) != 0
    if new.all():
        return rows, []  # no repeated stamp: no index array for a long log
    starts = np.flatnonzero(np.r_[True, new])
    counts = np.diff(np.r_[starts, rows.t.size])
    first = at(rows.row(starts[np.argmax(counts > 1)]))
    merged = (f"{int((counts > 1).sum())} time stamps repeat on "
              f"{int(counts[counts > 1].sum())} rows (the first at {first})")
    if options.duplicates == "first":
        return rows.take(starts), [f"duplicates: {merged}; the first row of each is kept"]
    u, y = (_nanmean(v, starts) for v in (rows.u, rows.y))
    return Rows(rows.t[starts], u, y, rows.indices(starts)), [
        f"duplicates: {merged}; each stamp's rows are merged into their mean"]


def _nanmean(values: np.ndarray, starts: np.ndarray) -> np.ndarray:
    """Mean of each group of rows (from each start to the next), ignoring empty cells."""
    full = np.isfinite(values)
    sums = np.add.reduceat(np.where(full, values, 0.0), starts)
    n = np.add.reduceat(full.astype(np.int64), starts)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(n > 0, sums / np.maximum(n, 1), np.nan)


def fill_gaps(rows: Rows, options: QuirkOptions, names: tuple[str, str],
              at: Places) -> tuple[Rows, list[str]]:
    """Drop-outs (empty input or output cells) filled, cut or refused by the policy."""
    empty = ~(np.isfinite(rows.u) & np.isfinite(rows.y))  # a sum would overflow at 1e300
    if not empty.any():
        return rows, []
    runs = _runs(empty)
    edge = [(a, b) for a, b in runs if a == 0 or b == rows.t.size]
    inner = [(a, b) for a, b in runs if (a, b) not in edge]
    long = [(a, b) for a, b in inner if b - a > options.fill_gaps]
    if options.fill_gaps == 0 or (long and options.long_gaps == "error"):
        a, b = (long or runs)[0]
        col, v = (names[0], rows.u[a]) if not np.isfinite(rows.u[a]) else (names[1], rows.y[a])
        what = (f"{b - a} rows without a value (a drop-out longer than fill_gaps: "
                f"{options.fill_gaps})" if options.fill_gaps else
                f"column {col!r} is {'empty' if np.isnan(v) else f'{v:g}'} (a drop-out)")
        if b - a == rows.t.size:
            raise at.error(rows.row(a), f"column {col!r} holds no number on any row (empty, "
                           "nan or inf); expected a signal")
        fix = ("set fill_gaps: N to fill drop-outs of up to N rows" if not options.fill_gaps
               else "set long_gaps: keep_longest to keep the longest stretch without one")
        raise at.error(rows.row(a), f"{what}; expected a number, or {fix}")
    notes = []
    keep = np.ones(rows.t.size, bool)
    for a, b in edge + long:
        keep[a:b] = False
    if long:
        pieces = _runs(keep)
        a, b = max(pieces, key=lambda p: p[1] - p[0])
        keep[:] = False
        keep[a:b] = True
        notes.append(f"long_gaps: {len(long)} drop-out(s) longer than {options.fill_gaps} "
                     f"rows; {at(rows.row(a))} to {at(rows.row(b - 1))} (the "
                     f"longest stretch without one, {b - a} rows) are kept")
    elif edge:
        notes.append(f"fill_gaps: {sum(b - a for a, b in edge)} rows with empty cells at the "
                     "start or end dropped")
    short = [(a, b) for a, b in inner if keep[a] and b - a <= options.fill_gaps]
    rows = _filled(rows)
    if short:
        notes.append(f"fill_gaps: {len(short)} drop-out(s) of up to "
                     f"{max(b - a for a, b in short)} rows filled (input held, output "
                     f"interpolated), the first at {at(rows.row(short[0][0]))}")
    return rows.take(keep), notes


def _runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """``[start, end)`` of each run of True."""
    edges = np.flatnonzero(np.diff(np.r_[0, mask.astype(np.int8), 0]))
    return list(zip(edges[::2].tolist(), edges[1::2].tolist(), strict=True))


def _filled(rows: Rows) -> Rows:
    """Every empty cell between two full rows filled: input held, output interpolated."""
    u = rows.u.copy()
    full_u = np.isfinite(u)
    last = np.maximum.accumulate(np.where(full_u, np.arange(u.size), 0))
    u = np.where(full_u, u, u[last])
    full_y = np.isfinite(rows.y)
    y = np.interp(rows.t, rows.t[full_y], rows.y[full_y]) if full_y.any() else rows.y
    y = np.where(full_y, rows.y, y)
    return Rows(rows.t, u, y, rows.index)
