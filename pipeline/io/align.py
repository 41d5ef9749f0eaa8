"""Two sampled signals onto one time grid: format-independent alignment with gap notes.

Alignment
    When both signals carry the same time stamps and no ``sample_time`` is given, the
    samples are used as logged. Otherwise both go onto one uniform grid over the overlap
    of the two signals: the step is ``sample_time`` or the output's median interval
    (rounded to 3 significant digits); the grid times are multiples of the step, from the
    first one at which both signals have begun. The input is held from its previous
    message (zero-order hold: it is a command, and a command holds until the next one,
    so the grid runs to the output's last sample); the output is interpolated linearly.

Gaps
    An interval in either signal longer than ``max_gap`` (default: 5 times the larger of
    that signal's median interval and the grid step) is reported in ``Record.notes`` with
    the signal's label, the start time and the length; it is never bridged without a note.

Used by the MCAP loader (:mod:`pipeline.io.mcap`), where the input and the output are
topics logged at their own rates; any loader of separately sampled signals can use it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import UserError

GAP_FACTOR = 5.0  # default max_gap: this many (median or grid) intervals
MAX_GAP_NOTES = 5  # gap notes per signal; the rest are counted


@dataclass(frozen=True)
class Sampled:
    """One signal's samples: ``t`` in seconds (sorted, distinct, finite), ``v`` values;
    ``label`` names it in the notes (e.g. ``input /lamp/cmd:data``)."""

    label: str
    t: np.ndarray
    v: np.ndarray


@dataclass(frozen=True)
class Aligned:
    """``t, u, y`` on one grid (seconds) and the notes saying how they were made."""

    t: np.ndarray
    u: np.ndarray
    y: np.ndarray
    notes: list[str]


def _median_step(t: np.ndarray) -> float:
    """Median interval of ``t`` (the differences are partitioned in place: no copy)."""
    return float(np.median(np.diff(t), overwrite_input=True)) if t.size > 1 else 0.0


def _nice(step: float) -> float:
    """``step`` rounded to 3 significant digits (a jittered 0.04998 s -> 0.05 s)."""
    return float(f"{step:.3g}") if step > 0 else step


def _gap_notes(t: np.ndarray, label: str, threshold: float, how: str,
               span: tuple[float, float]) -> list[str]:
    """One note per interval of ``t`` (seconds) longer than ``threshold`` inside ``span``."""
    if t.size < 2:
        return []
    d = np.diff(t)
    idx = np.flatnonzero((d > threshold) & (t[1:] > span[0]) & (t[:-1] < span[1]))
    notes = [f"gap in {label}: no message for {d[i]:.4g} s from t = {t[i]:.6g} s "
             f"(max_gap {threshold:.4g} s); {how}" for i in idx[:MAX_GAP_NOTES]]
    if idx.size > MAX_GAP_NOTES:
        notes.append(f"... and {idx.size - MAX_GAP_NOTES} more gaps in {label}")
    return notes


def _threshold(t: np.ndarray, step: float, max_gap: float | None) -> float:
    if max_gap is not None:
        return max_gap
    return GAP_FACTOR * max(_median_step(t), step)


def align(inp: Sampled, out: Sampled, *, sample_time: float | None, max_gap: float | None,
          source: str) -> Aligned:
    """The input and output on one time grid, with the alignment and gap notes (see the
    module docstring); ``source`` names the file in the error when they do not overlap."""
    if sample_time is None and np.array_equal(inp.t, out.t):
        ty = out.t
        step = _median_step(ty)
        span = (ty[0], ty[-1])
        notes = _gap_notes(ty, f"{inp.label} and {out.label}",
                           _threshold(ty, step, max_gap), "samples used as logged", span)
        return Aligned(ty, inp.v, out.v, notes)
    tu, ty = inp.t, out.t
    step = sample_time if sample_time is not None else _nice(_median_step(ty))
    start, end = _grid_start(max(tu[0], ty[0]), step), ty[-1]
    if step <= 0 or end - start < step:
        raise UserError(
            f"{source}: {inp.label} (t = {tu[0]:.6g} .. {tu[-1]:.6g} s) and "
            f"{out.label} (t = {ty[0]:.6g} .. {ty[-1]:.6g} s) do not overlap; "
            "expected both signals over the same time")
    grid = start + step * np.arange(int(math.floor((end - start) / step + 1e-9)) + 1)
    idx = np.searchsorted(tu, grid + 1e-9, side="right") - 1
    u = inp.v[idx]
    y = np.interp(grid, ty, out.v)
    notes = _alignment_notes(inp, out, (start, end), step, max_gap)
    return Aligned(grid, u, y, notes)


def _grid_start(first: float, step: float) -> float:
    """The first multiple of ``step`` (seconds since t = 0) at or after ``first``."""
    return math.ceil(first / step - 1e-9) * step if step > 0 else first


def _alignment_notes(inp: Sampled, out: Sampled, span: tuple[float, float], step: float,
                     max_gap: float | None) -> list[str]:
    tu, ty = inp.t, out.t
    start, end = span
    notes = [f"resampled onto a uniform grid of {step:.6g} s over t = {start:.6g} .. "
             f"{end:.6g} s: {inp.label} held (zero-order hold), "
             f"{out.label} interpolated linearly"]
    if ty[0] < start - step:
        notes.append(f"{out.label}: samples before the first input message "
                     f"(t < {start:.6g} s) dropped; the input is unknown there")
    thr_u, thr_y = _threshold(tu, step, max_gap), _threshold(ty, step, max_gap)
    notes += _gap_notes(tu, inp.label, thr_u, "input held at its last value", span)
    notes += _gap_notes(ty, out.label, thr_y, "output interpolated linearly across it",
                        span)
    if end - tu[-1] > thr_u:
        notes.append(f"gap in {inp.label}: no message for the last "
                     f"{end - tu[-1]:.4g} s (from t = {tu[-1]:.6g} s to the end of the output);"
                     " input held at its last value")
    return notes

