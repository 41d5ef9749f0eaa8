"""MCAP logs as input: one numeric field of one topic is the input, another the output.

Keys (``data:``, beside the common ones): ``stamp`` (the time base), ``sample_time`` (the
common grid step, s) and ``max_gap`` (longer silences are noted, s); ``input`` and
``output`` are ``{topic: ..., field: ...}``.

Signals
    A :class:`Signal` names a topic and a field path into its decoded messages: dotted
    names, array elements by index, e.g. ``temperature.value`` or ``position[2]``. On the
    command line a signal is ``TOPIC:FIELD`` (split at the last ``:``), e.g.
    ``/lamp/cmd:data``. Messages are decoded by their channel's message encoding: ROS 2
    CDR (``cdr`` with a ``ros2msg`` schema), ``protobuf`` and ``json``; any other encoding
    is a :class:`~pipeline.errors.UserError` naming the topic and the encoding
    (:mod:`.decode`).

Time base
    The log time of each message by default. With ``stamp`` (e.g. ``header.stamp``) the
    time is read from the message: a ``builtin_interfaces/Time`` (``sec``/``nanosec``;
    also ``secs``/``nsecs`` and protobuf's ``seconds``/``nanos``), a float in seconds or
    an integer in nanoseconds. A topic without that field keeps its log time (with a
    note); when neither signal has it, that is an error. Times in the record are seconds
    since the first sample of the two signals; a note keeps the absolute start.

Alignment and gaps
    The two signals go onto one time grid by :func:`pipeline.io.align.align` (samples used
    as logged when the stamps are identical, else a uniform grid: the input held, the
    output interpolated); an interval longer than ``max_gap`` is noted, never bridged
    silently.

Reading
    Only the chunks that hold the two topics are read, one at a time; a log without an
    index is scanned; a damaged or cut-off part is skipped with a note (:mod:`.reader`).
    :mod:`.inspect` lists what a log holds (``pipeline inspect``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from mcap.records import Channel
from pydantic import Field

from ...errors import UserError
from ...record import Record, make_record
from ..align import Sampled, align
from ..base import DataSection, Format, SignalConfig, Strict
from .decode import (
    NS,
    PATH_RE,
    SIGNAL_FORMS,
    Context,
    JsonDecoderFactory,
    Series,
    Signal,
    decoder_factories,
    parse_path,
    parse_signal,
)
from .inspect import format_inspect, inspect_mcap
from .reader import check_topics, read_series

__all__ = ["Signal", "parse_signal", "parse_path", "load_mcap", "inspect_mcap",
           "format_inspect", "JsonDecoderFactory", "decoder_factories", "McapOptions",
           "FORMAT"]

@dataclass(frozen=True)
class _Samples:
    """One signal's samples, time-sorted: ``t`` in ns, ``v`` values."""

    series: Series
    t: np.ndarray
    v: np.ndarray


#: Messages may arrive a little out of time order (two publishers, a transport's
#: latency) and are sorted, with a note. A step back by more than this many median
#: sample intervals, and by more than JUMP_BACK_SECONDS (a fast signal's latency), is a
#: clock that was reset or two recordings in one file: sorting would interleave them
#: into one record, so it is refused.
JUMP_BACK_INTERVALS = 10.0
JUMP_BACK_SECONDS = 1.0


def _samples(series: Series, notes: list[str], path: Path) -> _Samples:
    """Sort by time, drop non-finite values and repeated stamps (keep the last), with
    notes; a jump back in time (:data:`JUMP_BACK_INTERVALS`) is a UserError."""
    t = np.frombuffer(series.times, dtype=np.int64)
    v = np.frombuffer(series.values, dtype=np.float64)
    bad = ~np.isfinite(v)
    if bad.any():
        notes.append(f"{series.label}: {int(bad.sum())} non-finite values skipped")
        t, v = t[~bad], v[~bad]
    if t.size > 1 and bool((t[1:] < t[:-1]).any()):
        _check_order(series, t, notes, path)
        order = np.argsort(t, kind="stable")
        t, v = t[order], v[order]
    if t.size > 1:
        same = t[1:] == t[:-1]
        if same.any():
            keep = np.append(~same, True)
            notes.append(f"{series.label}: {int(same.sum())} messages repeat the time "
                         "stamp of the next one; the last of each is kept")
            t, v = t[keep], v[keep]
    return _Samples(series, t, v)


def _check_order(series: Series, t: np.ndarray, notes: list[str], path: Path
                 ) -> None:
    """Messages behind the latest time before them: by a little, a note (they are
    sorted); by more than :data:`JUMP_BACK_INTERVALS` median intervals and
    :data:`JUMP_BACK_SECONDS`, a UserError (its message counts the finite values in
    arrival order)."""
    behind = np.maximum.accumulate(t) - t
    d = np.diff(np.sort(t))  # the sample interval, not the arrival order's jitter
    step = float(np.median(d[d > 0])) if bool((d > 0).any()) else 0.0
    worst = int(np.argmax(behind))
    what = "header stamps" if series.stamped else "log times"
    if behind[worst] > max(JUMP_BACK_INTERVALS * step, JUMP_BACK_SECONDS * NS):
        hint = "; or omit stamp to use the log time" if series.stamped else ""
        raise UserError(
            f"{path}: {series.label}: its {what} jump back by {behind[worst] / NS:.3g} s at "
            f"message {worst + 1} of {t.size} finite ones (a clock reset, or two recordings "
            f"in one file?); expected time that goes forward: split the log at that "
            f"message{hint}")
    late = int((behind > 0).sum())
    notes.append(f"{series.label}: {late} messages arrived behind a later {what[:-1]} "
                 f"(by at most {behind[worst] / NS * 1e3:.3g} ms); sorted by time")


def _stamp_notes(series: list[Series], stamp: str | None, path: str) -> list[str]:
    """Notes for topics that fell back to log time; an error when none has the stamp."""
    if stamp is None:
        return []
    fallback = [s for s in series if s.stamped is False]
    if len(fallback) == len(series):
        s = series[0]
        raise UserError(f"{path}: stamp '{stamp}' found in neither topic "
                        f"('{s.signal.topic}' field '{s.signal.field}', ...); expected a "
                        "time field such as 'header.stamp' (omit stamp to use the log time)")
    return [f"{s.label}: the topic has no stamp '{stamp}'; its log time is used"
            for s in fallback]


def _check_read(path: Path, series: list[Series], channels: dict[int, Channel],
                damage: str | None, stamp: str | None) -> list[str]:
    """Errors for missing, empty or unreadable signals; notes for damage and stamps."""
    ctx = Context(str(path), None, stamp, [])
    empty = [s for s in series if len(s.values) == 0]
    if empty and damage:
        raise UserError(
            f"{path}: cannot read {' and '.join(s.label for s in empty)}: the file is "
            f"truncated or damaged before their messages ({damage}); expected a complete "
            "MCAP log")
    check_topics(ctx, series, channels, None)
    if empty:
        raise ctx.error(empty[0], "the topic has no messages; expected a logged signal")
    notes = _stamp_notes(series, stamp, str(path))
    if damage:
        n = sum(len(s.values) for s in series)
        notes.insert(0, f"part of the file is damaged or cut off ({damage}); the "
                        f"{n} values in its readable part were read")
    return notes


def load_mcap(path: str | Path, input: Signal, output: Signal, *, stamp: str | None = None,
              sample_time: float | None = None, max_gap: float | None = None,
              initial_input: float | None = None, name: str | None = None,
              units: dict[str, str] | None = None) -> Record:
    """Read the ``input`` and ``output`` signals of an MCAP log into a :class:`Record`.

    See the module docstring for the time base, the alignment and the gap notes. Every
    problem with the file, a topic or a field is a :class:`~pipeline.errors.UserError`
    with one line naming the file, the topic and the field.
    """
    path = Path(path)
    _check_options(path, input, output, sample_time, max_gap)
    t, u, y, notes = _extract(path, input, output, stamp, sample_time, max_gap)
    return make_record(t, u, y, name=name or path.stem, source=str(path), units=units,
                       initial_input=initial_input, input_name=str(input),
                       output_name=str(output), notes=tuple(notes))


def _extract(path: Path, input: Signal, output: Signal, stamp: str | None,
             sample_time: float | None, max_gap: float | None
             ) -> tuple[np.ndarray, np.ndarray, np.ndarray, list[str]]:
    """``t, u, y`` and the notes; the read buffers are released when it returns."""
    series, channels, notes, damage = read_series(
        path, [("input", input), ("output", output)], stamp)
    notes += _check_read(path, series, channels, damage, stamp)
    inp, out = (_samples(s, notes, path) for s in series)
    for s in (inp, out):
        if s.t.size == 0:
            raise UserError(f"{path}: topic '{s.series.signal.topic}' field "
                            f"'{s.series.signal.field}' has no finite values; expected numbers")
    t0 = int(min(inp.t[0], out.t[0]))
    grid = align(*(Sampled(s.series.label, (s.t - t0) / NS, s.v) for s in (inp, out)),
                 sample_time=sample_time, max_gap=max_gap, source=str(path))
    base = "header stamp" if stamp and any(s.stamped for s in series) else "log time"
    return grid.t, grid.u, grid.y, [f"t = 0 is {base} {t0 // NS}.{t0 % NS:09d} s", *notes,
                                    *grid.notes]


def _check_options(path: Path, input: Signal, output: Signal, sample_time: float | None,
                   max_gap: float | None) -> None:
    for role, sig in (("input", input), ("output", output)):
        if not sig.topic or not PATH_RE.fullmatch(sig.field):
            raise UserError(f"{path}: {role} topic '{sig.topic}' field '{sig.field}': "
                            f"expected a topic and a field path, {SIGNAL_FORMS}")
    for key, value in (("sample_time", sample_time), ("max_gap", max_gap)):
        if value is not None and not (math.isfinite(value) and value > 0):
            raise UserError(f"{path}: {key} = {value}; expected a positive number of seconds")


# -- the registry entry -----------------------------------------------------------------


class McapOptions(Strict):
    """The keys of an MCAP log: ``stamp``, ``sample_time`` and ``max_gap`` (see above)."""

    stamp: str | None = None
    sample_time: float | None = Field(None, gt=0)
    max_gap: float | None = Field(None, gt=0)


def load_mcap_record(path: Path, data: DataSection, options: McapOptions,
                     name: str) -> Record:
    """The registry's loader: :func:`load_mcap` with the ``data:`` section's signals."""
    if not isinstance(data.input, SignalConfig) or not isinstance(data.output, SignalConfig):
        raise UserError(
            f"{path}: an MCAP input/output is a topic and field, e.g. "
            "input: {topic: /lamp/cmd, field: data}"
        )
    return load_mcap(
        path, Signal(data.input.topic, data.input.field),
        Signal(data.output.topic, data.output.field), stamp=options.stamp,
        sample_time=options.sample_time, max_gap=options.max_gap,
        initial_input=data.initial_input, name=name, units=data.unit_map(),
    )


def signal_config(text: str) -> SignalConfig:
    """A command-line ``TOPIC:FIELD`` as the ``data.input``/``data.output`` value."""
    sig = parse_signal(text)
    return SignalConfig(topic=sig.topic, field=sig.field)


FORMAT = Format("mcap", (".mcap",), McapOptions, load_mcap_record,
                parse_signal=signal_config)
