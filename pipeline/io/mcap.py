"""MCAP logs as input: one numeric field of one topic is the input, another the output.

Signals
    A :class:`Signal` names a topic and a field path into its decoded messages: dotted
    names, array elements by index, e.g. ``temperature.value`` or ``position[2]``. On the
    command line a signal is ``TOPIC:FIELD`` (split at the last ``:``), e.g.
    ``/lamp/cmd:data``. Messages are decoded by their channel's message encoding: ROS 2
    CDR (``cdr`` with a ``ros2msg`` schema), ``protobuf`` and ``json``; any other encoding
    is a :class:`~pipeline.errors.UserError` naming the topic and the encoding.

Time base
    The log time of each message by default. With ``stamp`` (e.g. ``header.stamp``) the
    time is read from the message: a ``builtin_interfaces/Time`` (``sec``/``nanosec``;
    also ``secs``/``nsecs`` and protobuf's ``seconds``/``nanos``), a float in seconds or
    an integer in nanoseconds. A topic without that field keeps its log time (with a
    note); when neither signal has it, that is an error. Times in the record are seconds
    since the first sample of the two signals; a note keeps the absolute start.

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
    the topic, the start time and the length; it is never bridged without a note.

Reading
    Through the summary's chunk index, only the chunks whose message index lists the two
    topics are read, one at a time (decompressed and CRC-checked with mcap's record
    classes); inside a chunk the records are walked with ``struct`` and only the wanted
    channels' payloads are copied. Values go straight into ``array('d')`` buffers, so
    memory follows the selected signals, not the file size. ``std_msgs`` scalars
    (``Float64`` ...) are unpacked from the CDR bytes; everything else goes through the
    library decoders. A file without a summary or chunk index (a log cut off by a crash)
    is read by a sequential scan with mcap's ``StreamReader``, with a note; a file that
    ends in the middle of a record keeps the complete part before it, and a damaged chunk
    is skipped, with a note (and the gap it leaves is reported as a gap).
"""

from __future__ import annotations

import json
import math
import re
import struct
from array import array
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, BinaryIO

import numpy as np
from mcap.data_stream import ReadDataStream
from mcap.decoder import DecoderFactory
from mcap.exceptions import EndOfFile, McapError
from mcap.reader import SeekingReader
from mcap.records import Channel, Chunk, ChunkIndex, Message, MessageIndex, Schema
from mcap.stream_reader import StreamReader, get_chunk_data_stream
from mcap.summary import Summary
from mcap_protobuf.decoder import DecoderFactory as ProtobufDecoderFactory
from mcap_ros2.decoder import DecoderFactory as Ros2DecoderFactory

from ..errors import UserError
from ..record import Record, make_record

if TYPE_CHECKING:
    from rich.table import Table

__all__ = ["Signal", "parse_signal", "parse_path", "load_mcap", "inspect_mcap",
           "format_inspect", "JsonDecoderFactory", "decoder_factories"]

NS = 1_000_000_000
GAP_FACTOR = 5.0  # default max_gap: this many (median or grid) intervals
MAX_GAP_NOTES = 5  # gap notes per signal; the rest are counted
SIGNAL_FORMS = "e.g. '/lamp/cmd:data' or '/plate/temp:temperature.value'"

# -- signals and field paths ------------------------------------------------------------

_NAME = r"[^.\[\]\s:]+"
_PATH_RE = re.compile(rf"{_NAME}(?:\[\d+\])*(?:\.{_NAME}(?:\[\d+\])*)*")
_TOKEN_RE = re.compile(rf"({_NAME})|\[(\d+)\]")

FieldPath = tuple[str | int, ...]


@dataclass(frozen=True)
class Signal:
    """A numeric field of a topic: ``field`` is a dotted path, array elements by index
    (``"temperature.value"``, ``"position[2]"``)."""

    topic: str
    field: str

    def __str__(self) -> str:
        return f"{self.topic}:{self.field}"


def parse_signal(text: str) -> Signal:
    """``"/lamp/cmd:data"`` -> ``Signal("/lamp/cmd", "data")``, split at the last ``:``."""
    topic, sep, fld = text.strip().rpartition(":")
    if not sep or not topic or not _PATH_RE.fullmatch(fld):
        raise UserError(
            f"signal '{text}': expected TOPIC:FIELD, {SIGNAL_FORMS} (FIELD: dotted names, "
            "array elements as [index])")
    return Signal(topic, fld)


def parse_path(text: str) -> FieldPath:
    """``"a.b[2].c"`` -> ``("a", "b", 2, "c")``; ``ValueError`` when malformed."""
    if not _PATH_RE.fullmatch(text):
        raise ValueError(f"malformed field path {text!r}")
    return tuple(int(i) if i else name for name, i in _TOKEN_RE.findall(text))


def _resolve(obj: Any, path: FieldPath) -> Any:
    """Follow ``path`` into a decoded message: dict keys, attributes, sequence indexes.

    Raises ``LookupError``, ``AttributeError`` or ``TypeError`` when a step is missing.
    """
    for key in path:
        if key.__class__ is int or obj.__class__ is dict:
            obj = obj[key]
        else:
            obj = getattr(obj, key)
    return obj


def _number(value: Any) -> float | None:
    """``value`` as a float when it is a real number (bool counts as 0/1), else None."""
    if isinstance(value, int | float | np.integer | np.floating | np.bool_):
        return float(value)
    return None


def _children(obj: Any) -> list[tuple[str | int, Any]]:
    """The named or indexed parts of a decoded message value (empty for a leaf)."""
    if isinstance(obj, str | bytes | bytearray) or _number(obj) is not None:
        return []
    if isinstance(obj, dict):
        return list(obj.items())
    descriptor = getattr(obj, "DESCRIPTOR", None)
    if descriptor is not None and hasattr(descriptor, "fields"):  # protobuf message
        return [(f.name, getattr(obj, f.name)) for f in descriptor.fields]
    slots = getattr(type(obj), "__slots__", None)
    if slots and not isinstance(obj, list | tuple):  # ROS 2 decoded message
        return [(name, getattr(obj, name, None)) for name in slots]
    if hasattr(obj, "__len__") and hasattr(obj, "__getitem__"):
        return list(enumerate(obj))
    return []


def _join(prefix: str, key: str | int) -> str:
    if isinstance(key, int):
        return f"{prefix}[{key}]"
    return f"{prefix}.{key}" if prefix else key


def numeric_paths(obj: Any, prefix: str = "", depth: int = 8) -> list[str]:
    """Field paths of the numeric leaves of a decoded message (long arrays summarised as
    ``name[0..n-1]``; byte blobs and strings are left out)."""
    kids = _children(obj)
    if not kids:
        return [prefix] if prefix and _number(obj) is not None else []
    if depth <= 0:
        return []
    if isinstance(kids[0][0], int) and len(kids) > 4:
        if all(_number(v) is not None for _, v in kids[:16]):
            return [f"{prefix}[0..{len(kids) - 1}]"]
        kids = kids[:1]
    out: list[str] = []
    for key, value in kids:
        out += numeric_paths(value, _join(prefix, key), depth - 1)
    return out


def _miss_reason(obj: Any, path: FieldPath) -> str:
    """Why ``path`` does not resolve in ``obj``: the first missing step and what exists."""
    done = ""
    for key in path:
        kids = _children(obj)
        found = [v for k, v in kids if k == key]
        if not found:
            names = [str(k) for k, _ in kids if not isinstance(k, int)]
            there = (f"[0..{len(kids) - 1}]" if kids and isinstance(kids[0][0], int)
                     else ", ".join(names[:12]) or type(obj).__name__)
            return f"no '{_join('', key).lstrip('.')}' in {done or 'the message'} (it has: {there})"
        obj, done = found[0], _join(done, key)
    return "unreadable"


# -- decoding ---------------------------------------------------------------------------


class JsonDecoderFactory(DecoderFactory):
    """Decodes channels with message encoding ``json`` by ``json.loads``."""

    def decoder_for(self, message_encoding: str,
                    schema: Schema | None) -> Callable[[bytes], Any] | None:
        return json.loads if message_encoding == "json" else None


def decoder_factories() -> list[DecoderFactory]:
    """The decoders this module reads: ROS 2 CDR, protobuf, JSON."""
    return [Ros2DecoderFactory(), ProtobufDecoderFactory(), JsonDecoderFactory()]


SUPPORTED = "cdr (ros2msg schema), protobuf, json"

# std_msgs scalar wrappers: the value is the first field, right after the 4-byte CDR
# encapsulation header (offset 0 of the payload is aligned for every primitive).
_CDR_SCALARS = {"float64": "d", "float32": "f", "int8": "b", "uint8": "B", "byte": "B",
                "char": "b", "bool": "?", "int16": "h", "uint16": "H", "int32": "i",
                "uint32": "I", "int64": "q", "uint64": "Q"}


def _cdr_scalar_format(schema: Schema | None, channel: Channel) -> str | None:
    """struct format of ``data`` when the channel carries a one-field ``std_msgs`` scalar."""
    if (schema is None or channel.message_encoding != "cdr" or schema.encoding != "ros2msg"
            or not schema.name.startswith("std_msgs/")):
        return None
    lines = [ln.split("#", 1)[0].strip() for ln in schema.data.decode(errors="replace")
             .splitlines()]
    lines = [ln for ln in lines if ln]
    if len(lines) != 1 or len(lines[0].split()) != 2:
        return None
    ftype, name = lines[0].split()
    return _CDR_SCALARS.get(ftype) if name == "data" else None


# -- accumulation -----------------------------------------------------------------------


@dataclass
class _Series:
    """Times (ns) and values of one signal, appended message by message."""

    signal: Signal
    role: str  # "input" | "output"
    times: array = field(default_factory=lambda: array("q"))
    values: array = field(default_factory=lambda: array("d"))
    stamped: bool | None = None  # None: undecided; False: fell back to log time

    @property
    def label(self) -> str:
        return f"{self.role} {self.signal}"


@dataclass
class _Context:
    """What the handlers need to know to read and to explain a failure."""

    path: str
    stamp: FieldPath | None
    stamp_text: str | None
    factories: list[DecoderFactory]

    def error(self, series: _Series, what: str) -> UserError:
        sig = series.signal
        return UserError(f"{self.path}: topic '{sig.topic}' field '{sig.field}' "
                         f"({series.role}): {what}")


Handler = Callable[[int, bytes], None]  # (log time in ns, message payload)


def _make_handler(ctx: _Context, schema: Schema | None, channel: Channel,
                  series: list[_Series]) -> Handler:
    """The per-message function of one channel: decode, pick the fields, append."""
    fmt = _cdr_scalar_format(schema, channel)
    if fmt is not None and ctx.stamp is None and all(s.signal.field == "data" for s in series):
        return _cdr_scalar_handler(series, fmt, _lazy(
            lambda: _decoding_handler(ctx, schema, channel, series)))
    return _decoding_handler(ctx, schema, channel, series)


def _lazy(build: Callable[[], Handler]) -> Handler:
    """A handler built on its first message."""
    built: list[Handler] = []

    def handle(log_time: int, data: bytes) -> None:
        if not built:
            built.append(build())
        built[0](log_time, data)

    return handle


def _decoding_handler(ctx: _Context, schema: Schema | None, channel: Channel,
                      series: list[_Series]) -> Handler:
    """Decode with the library's decoder, then read each signal's field."""
    decode = _decoder(ctx, schema, channel, series[0])
    extractors = [_extractor(ctx, s) for s in series]

    def handle(log_time: int, data: bytes) -> None:
        try:
            obj = decode(data)
        except Exception as exc:  # any decoder failure is a damaged message
            raise ctx.error(series[0], _decode_failure(channel, log_time, exc)) from exc
        for extract in extractors:
            extract(obj, log_time)

    return handle


def _decode_failure(channel: Channel, log_time: int, exc: Exception) -> str:
    return (f"message at log time {log_time / NS:.9f} s could not be decoded as "
            f"{channel.message_encoding} ({type(exc).__name__}: {exc}); expected a valid "
            "message")


def _cdr_scalar_handler(series: list[_Series], fmt: str, generic: Handler) -> Handler:
    """Fast path for ``std_msgs`` scalars: the value is unpacked from the CDR bytes
    (little- or big-endian plain CDR); any other payload goes to the full decoder."""
    unpack = {1: struct.Struct("<" + fmt).unpack_from, 0: struct.Struct(">" + fmt).unpack_from}
    need = 4 + struct.calcsize(fmt)
    sinks = [(s.times.append, s.values.append) for s in series]
    if len(sinks) == 1 and fmt == "d":
        (tappend, vappend), = sinks
        unpack_le = unpack[1]

        def handle_float64(log_time: int, data: bytes) -> None:
            if len(data) >= 12 and data[1] == 1 and data[0] == 0:
                tappend(log_time)
                vappend(unpack_le(data, 4)[0])
            else:
                generic(log_time, data)

        return handle_float64

    def handle(log_time: int, data: bytes) -> None:
        if len(data) < need or data[0] != 0 or data[1] > 1:
            generic(log_time, data)
            return
        value = float(unpack[data[1]](data, 4)[0])
        for tappend, vappend in sinks:
            tappend(log_time)
            vappend(value)

    return handle


def _decoder(ctx: _Context, schema: Schema | None, channel: Channel,
             series: _Series) -> Callable[[bytes], Any]:
    """The library decoder for a channel; an unsupported encoding is a UserError."""
    schema_enc = schema.encoding if schema is not None else "none"
    for factory in ctx.factories:
        try:
            decode = factory.decoder_for(channel.message_encoding, schema)
        except Exception as exc:  # a schema the library cannot parse
            raise ctx.error(series, (
                f"schema '{schema.name if schema else ''}' ({schema_enc}) cannot be parsed "
                f"({type(exc).__name__}: {exc}); expected a valid schema")) from exc
        if decode is not None:
            return decode
    raise ctx.error(series, (
        f"message encoding '{channel.message_encoding}' (schema encoding '{schema_enc}') "
        f"is not supported; expected one of: {SUPPORTED}"))


def _extractor(ctx: _Context, series: _Series) -> Callable[[Any, int], None]:
    """Reads the field (and the stamp, if asked) of one signal from a decoded message."""
    path = parse_path(series.signal.field)
    tappend, vappend = series.times.append, series.values.append
    stamp_of = _stamp_reader(ctx, series)

    def extract(obj: Any, log_time: int) -> None:
        try:
            value = _resolve(obj, path)
        except (LookupError, AttributeError, TypeError):
            raise ctx.error(series, (
                f"{_miss_reason(obj, path)}; expected a numeric field, e.g. "
                f"{', '.join(numeric_paths(obj)[:6]) or '(none in this message)'}")) from None
        if value.__class__ is not float:
            number = _number(value)
            if number is None:
                raise ctx.error(series, (
                    f"is {type(value).__name__} ({_short(value)}), expected a number"))
            value = number
        tappend(log_time if stamp_of is None else stamp_of(obj, log_time))
        vappend(value)

    return extract


def _short(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= 40 else text[:37] + "..."


def _stamp_reader(ctx: _Context, series: _Series) -> Callable[[Any, int], int] | None:
    """Time (ns) of a message from its stamp field; decided on the first message whether
    this topic has the field (else its log time is used, with a note)."""
    if ctx.stamp is None:
        return None
    path = ctx.stamp
    convert: list[Callable[[Any], int]] = []

    def stamp_of(obj: Any, log_time: int) -> int:
        if series.stamped is False:
            return log_time
        try:
            value = _resolve(obj, path)
        except (LookupError, AttributeError, TypeError):
            if series.stamped is None:
                series.stamped = False
                return log_time
            raise ctx.error(series, f"a message at log time {log_time / NS:.9f} s "
                                    f"has no stamp '{ctx.stamp_text}'") from None
        if not convert:
            convert.append(_stamp_converter(ctx, series, value))
            series.stamped = True
        return convert[0](value)

    return stamp_of


_STAMP_PAIRS = (("sec", "nanosec"), ("secs", "nsecs"), ("seconds", "nanos"))


def _stamp_converter(ctx: _Context, series: _Series, sample: Any) -> Callable[[Any], int]:
    """Chooses how a stamp value becomes integer nanoseconds, from the first one seen."""
    for sec, nsec in _STAMP_PAIRS:
        if isinstance(sample, dict) and sec in sample and nsec in sample:
            return lambda v, s=sec, n=nsec: int(v[s]) * NS + int(v[n])
        if hasattr(sample, sec) and hasattr(sample, nsec):
            return lambda v, s=sec, n=nsec: int(getattr(v, s)) * NS + int(getattr(v, n))
    if isinstance(sample, float):
        return _float_seconds_ns
    if isinstance(sample, int) and not isinstance(sample, bool):
        return int
    raise ctx.error(series, (
        f"stamp '{ctx.stamp_text}' is {type(sample).__name__} ({_short(sample)}); expected "
        "a time (sec, nanosec), float seconds or integer nanoseconds"))


def _float_seconds_ns(value: float) -> int:
    whole = math.floor(value)
    return int(whole) * NS + round((value - whole) * NS)


# -- reading the file -------------------------------------------------------------------


def _open(path: Path) -> BinaryIO:
    try:
        return open(path, "rb")
    except OSError as exc:
        raise UserError(f"{path}: cannot open ({exc.strerror}); expected a readable MCAP "
                        "file") from None


def _seeking_reader(f: BinaryIO, path: Path) -> SeekingReader:
    try:
        return SeekingReader(f)
    except (McapError, struct.error, EOFError) as exc:
        raise UserError(f"{path}: not an MCAP file ({type(exc).__name__}); expected an "
                        "MCAP log starting with the MCAP magic bytes") from None


def _summary(reader: SeekingReader) -> tuple[Summary | None, str | None]:
    """The summary when it has a chunk index, else ``None`` and the reason (a note)."""
    try:
        summary = reader.get_summary()
    except Exception:  # whatever a missing or damaged footer makes the reader raise
        return None, ("no summary or index at the end of the file (a log cut "
                      "off, e.g. by a crash?); read by a sequential scan")
    if summary is None or not summary.chunk_indexes:
        return None, "the file has no chunk index; read by a sequential scan"
    return summary, None


def _scan(f: BinaryIO, topics: set[str] | None,
          channels: dict[int, Channel]) -> Iterator[tuple[Schema | None, Channel, Message]]:
    """Sequential scan with mcap's StreamReader; ``channels`` collects what it sees."""
    f.seek(0)
    schemas: dict[int, Schema] = {}
    for record in StreamReader(f).records:
        if isinstance(record, Message):
            channel = channels.get(record.channel_id)
            if channel is not None and (topics is None or channel.topic in topics):
                yield schemas.get(channel.schema_id), channel, record
        elif isinstance(record, Channel):
            channels[record.id] = record
        elif isinstance(record, Schema):
            schemas[record.id] = record


_RECORD = struct.Struct("<BQ")  # MCAP record framing: opcode, length
_MESSAGE = struct.Struct("<HIQ")  # Message record: channel id, sequence, log time, ...
_MESSAGE_OPCODE = 0x05
_MESSAGE_DATA = 22  # channel id (2) + sequence (4) + log time (8) + publish time (8)


def _chunks_for(summary: Summary, channel_ids: set[int]) -> list[ChunkIndex]:
    """The chunks that may hold these channels (all, where a chunk has no message
    index), in log-time order."""
    chunks = [c for c in summary.chunk_indexes
              if not c.message_index_offsets or channel_ids & c.message_index_offsets.keys()]
    return sorted(chunks, key=lambda c: (c.message_start_time, c.chunk_start_offset))


def _chunk_records(f: BinaryIO, index: ChunkIndex) -> bytes:
    """The decompressed records of one chunk, read with mcap's record classes (its CRC
    checked, when the writer stored one)."""
    f.seek(index.chunk_start_offset + 9)  # past the opcode (1) and the length (8)
    stream, size = get_chunk_data_stream(Chunk.read(ReadDataStream(f)), validate_crc=True)
    return stream.read(size)


def _chunk_messages(data: bytes, handlers: dict[int, Handler]) -> None:
    """Hand each message in a chunk's records whose channel has a handler to it; other
    messages (a bulky camera topic, say) are skipped without being copied."""
    record, message = _RECORD.unpack_from, _MESSAGE.unpack_from
    pos, end = 0, len(data)
    while pos < end:
        opcode, length = record(data, pos)
        body = pos + 9
        pos = body + length
        if opcode == _MESSAGE_OPCODE:
            channel_id, _, log_time = message(data, body)
            handler = handlers.get(channel_id)
            if handler is not None:
                handler(log_time, data[body + _MESSAGE_DATA:pos])


def _read_indexed(f: BinaryIO, summary: Summary, ctx: _Context,
                  by_topic: dict[str, list[_Series]]) -> str | None:
    """Read only the chunks that hold the signals' channels, one chunk at a time; a
    damaged chunk is skipped (the complete messages before the damage are kept) and
    described in the returned text."""
    handlers = {cid: _make_handler(ctx, summary.schemas.get(c.schema_id), c, by_topic[c.topic])
                for cid, c in summary.channels.items() if c.topic in by_topic}
    damaged: list[str] = []
    for index in _chunks_for(summary, set(handlers)):
        problem = _guarded(lambda i=index: _chunk_messages(_chunk_records(f, i), handlers))
        if problem is not None:
            damaged.append(f"chunk at byte {index.chunk_start_offset}: {problem}")
    if not damaged:
        return None
    more = f"; and {len(damaged) - 3} more damaged chunks" if len(damaged) > 3 else ""
    return "; ".join(damaged[:3]) + more


def _read_scan(f: BinaryIO, ctx: _Context, by_topic: dict[str, list[_Series]],
               channels: dict[int, Channel]) -> None:
    """Read a file without a chunk index by one sequential scan."""
    handlers: dict[int, Handler] = {}
    for schema, channel, message in _scan(f, set(by_topic), channels):
        handler = handlers.get(channel.id)
        if handler is None:
            handler = _make_handler(ctx, schema, channel, by_topic[channel.topic])
            handlers[channel.id] = handler
        handler(message.log_time, message.data)


def _guarded(read: Callable[[], None]) -> str | None:
    """Run a read; the reader's failure on a damaged or truncated file is returned as
    text (the values read before it are kept), a UserError is raised."""
    try:
        read()
    except UserError:
        raise
    except Exception as exc:  # whatever a damaged file makes the reader raise
        return _damage_text(exc)
    return None


def _damage_text(exc: Exception) -> str:
    if isinstance(exc, struct.error | EndOfFile):
        return "a record is cut off"
    return f"{type(exc).__name__}: {exc}" if str(exc) else type(exc).__name__


def _read_series(path: Path, signals: list[tuple[str, Signal]], stamp: str | None
                 ) -> tuple[list[_Series], dict[int, Channel], list[str], str | None]:
    """Read the signals' messages: series, the channels known, notes, damage text."""
    ctx = _Context(str(path), _stamp_path(stamp, path), stamp, decoder_factories())
    series = [_Series(sig, role) for role, sig in signals]
    by_topic: dict[str, list[_Series]] = {}
    for s in series:
        by_topic.setdefault(s.signal.topic, []).append(s)
    with _open(path) as f:
        summary, problem = _summary(_seeking_reader(f, path))
        if summary is not None:
            channels = dict(summary.channels)
            _check_topics(ctx, series, channels, summary)
            damage = _read_indexed(f, summary, ctx, by_topic)
            return series, channels, [], damage
        channels = {}
        damage = _guarded(lambda: _read_scan(f, ctx, by_topic, channels))
    return series, channels, [problem or ""], damage


def _stamp_path(stamp: str | None, path: Path) -> FieldPath | None:
    if stamp is None:
        return None
    try:
        return parse_path(stamp)
    except ValueError:
        raise UserError(f"{path}: stamp '{stamp}' is not a field path; expected e.g. "
                        "'header.stamp'") from None


def _check_topics(ctx: _Context, series: list[_Series], channels: dict[int, Channel],
                  summary: Summary | None) -> None:
    """Missing and (when the statistics say so) empty topics are UserErrors."""
    known = {c.topic for c in channels.values()}
    for s in series:
        if s.signal.topic not in known:
            raise ctx.error(s, (f"topic not found; expected one of: "
                                f"{', '.join(sorted(known)) or '(no topics)'}"))
    stats = summary.statistics if summary is not None else None
    if stats is None:
        return
    for s in series:
        ids = [c.id for c in channels.values() if c.topic == s.signal.topic]
        if sum(stats.channel_message_counts.get(i, 0) for i in ids) == 0:
            raise ctx.error(s, "the topic has no messages; expected a logged signal")


# -- from series to record --------------------------------------------------------------


@dataclass(frozen=True)
class _Samples:
    """One signal's samples, time-sorted: ``t`` in ns, ``v`` values."""

    series: _Series
    t: np.ndarray
    v: np.ndarray


def _samples(series: _Series, notes: list[str]) -> _Samples:
    """Sort by time, drop non-finite values and repeated stamps (keep the last), with notes."""
    t = np.frombuffer(series.times, dtype=np.int64)
    v = np.frombuffer(series.values, dtype=np.float64)
    bad = ~np.isfinite(v)
    if bad.any():
        notes.append(f"{series.label}: {int(bad.sum())} non-finite values skipped")
        t, v = t[~bad], v[~bad]
    if t.size > 1 and bool((t[1:] < t[:-1]).any()):
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


def _aligned(inp: _Samples, out: _Samples, t0: int, sample_time: float | None,
             max_gap: float | None, path: str
             ) -> tuple[np.ndarray, np.ndarray, np.ndarray, list[str]]:
    """``t, u, y`` (seconds since ``t0``) and the alignment notes."""
    if sample_time is None and np.array_equal(inp.t, out.t):
        ty = (out.t - t0) / NS
        step = _median_step(ty)
        span = (ty[0], ty[-1])
        notes = _gap_notes(ty, f"{inp.series.label} and {out.series.label}",
                           _threshold(ty, step, max_gap), "samples used as logged", span)
        return ty, inp.v, out.v, notes
    tu, ty = (inp.t - t0) / NS, (out.t - t0) / NS
    step = sample_time if sample_time is not None else _nice(_median_step(ty))
    start, end = _grid_start(max(tu[0], ty[0]), step), ty[-1]
    if step <= 0 or end - start < step:
        raise UserError(
            f"{path}: {inp.series.label} (t = {tu[0]:.6g} .. {tu[-1]:.6g} s) and "
            f"{out.series.label} (t = {ty[0]:.6g} .. {ty[-1]:.6g} s) do not overlap; "
            "expected both signals over the same time")
    grid = start + step * np.arange(int(math.floor((end - start) / step + 1e-9)) + 1)
    idx = np.searchsorted(tu, grid + 1e-9, side="right") - 1
    u = inp.v[idx]
    y = np.interp(grid, ty, out.v)
    notes = _alignment_notes(inp, out, tu, ty, (start, end), step, max_gap)
    return grid, u, y, notes


def _grid_start(first: float, step: float) -> float:
    """The first multiple of ``step`` (seconds since t = 0) at or after ``first``."""
    return math.ceil(first / step - 1e-9) * step if step > 0 else first


def _alignment_notes(inp: _Samples, out: _Samples, tu: np.ndarray, ty: np.ndarray,
                     span: tuple[float, float], step: float, max_gap: float | None
                     ) -> list[str]:
    start, end = span
    notes = [f"resampled onto a uniform grid of {step:.6g} s over t = {start:.6g} .. "
             f"{end:.6g} s: {inp.series.label} held (zero-order hold), "
             f"{out.series.label} interpolated linearly"]
    if ty[0] < start - step:
        notes.append(f"{out.series.label}: samples before the first input message "
                     f"(t < {start:.6g} s) dropped; the input is unknown there")
    thr_u, thr_y = _threshold(tu, step, max_gap), _threshold(ty, step, max_gap)
    notes += _gap_notes(tu, inp.series.label, thr_u, "input held at its last value", span)
    notes += _gap_notes(ty, out.series.label, thr_y, "output interpolated linearly across it",
                        span)
    if end - tu[-1] > thr_u:
        notes.append(f"gap in {inp.series.label}: no message for the last "
                     f"{end - tu[-1]:.4g} s (from t = {tu[-1]:.6g} s to the end of the output);"
                     " input held at its last value")
    return notes


def _stamp_notes(series: list[_Series], stamp: str | None, path: str) -> list[str]:
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


def _check_read(path: Path, series: list[_Series], channels: dict[int, Channel],
                damage: str | None, stamp: str | None) -> list[str]:
    """Errors for missing, empty or unreadable signals; notes for damage and stamps."""
    ctx = _Context(str(path), None, stamp, [])
    empty = [s for s in series if len(s.values) == 0]
    if empty and damage:
        raise UserError(
            f"{path}: cannot read {' and '.join(s.label for s in empty)}: the file is "
            f"truncated or damaged before their messages ({damage}); expected a complete "
            "MCAP log")
    _check_topics(ctx, series, channels, None)
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
    series, channels, notes, damage = _read_series(
        path, [("input", input), ("output", output)], stamp)
    notes += _check_read(path, series, channels, damage, stamp)
    inp, out = (_samples(s, notes) for s in series)
    for s in (inp, out):
        if s.t.size == 0:
            raise UserError(f"{path}: topic '{s.series.signal.topic}' field "
                            f"'{s.series.signal.field}' has no finite values; expected numbers")
    t0 = int(min(inp.t[0], out.t[0]))
    t, u, y, align_notes = _aligned(inp, out, t0, sample_time, max_gap, str(path))
    base = "header stamp" if stamp and any(s.stamped for s in series) else "log time"
    return t, u, y, [f"t = 0 is {base} {t0 // NS}.{t0 % NS:09d} s", *notes, *align_notes]


def _check_options(path: Path, input: Signal, output: Signal, sample_time: float | None,
                   max_gap: float | None) -> None:
    for role, sig in (("input", input), ("output", output)):
        if not sig.topic or not _PATH_RE.fullmatch(sig.field):
            raise UserError(f"{path}: {role} topic '{sig.topic}' field '{sig.field}': "
                            f"expected a topic and a field path, {SIGNAL_FORMS}")
    for key, value in (("sample_time", sample_time), ("max_gap", max_gap)):
        if value is not None and not (math.isfinite(value) and value > 0):
            raise UserError(f"{path}: {key} = {value}; expected a positive number of seconds")


# -- inspect ----------------------------------------------------------------------------


def inspect_mcap(path: str | Path) -> dict:
    """What a log holds: per topic the schema, encodings, message count, time span (unix
    seconds) and the numeric field paths of its first message; plus file-level notes.

    Uses the summary (statistics, chunk and message indexes) when present; otherwise one
    sequential scan.
    """
    path = Path(path)
    with _open(path) as f:
        reader = _seeking_reader(f, path)
        summary, problem = _summary(reader)
        indexed = summary is not None and summary.statistics is not None
        if indexed:
            topics, notes = _inspect_indexed(f, summary), []
        else:
            topics, notes = _inspect_scan(f, path, problem)
    for t in topics:
        t["rate_hz"] = _rate(t)
    starts = [t["start"] for t in topics if t["start"] is not None]
    ends = [t["end"] for t in topics if t["end"] is not None]
    start, end = (min(starts), max(ends)) if starts and ends else (None, None)
    return {"path": str(path), "indexed": indexed, "notes": notes,
            "message_count": sum(t["count"] for t in topics), "start": start, "end": end,
            "duration": None if start is None else end - start, "topics": topics}


def _rate(topic: dict) -> float | None:
    if topic["count"] < 2 or topic["start"] is None or topic["end"] <= topic["start"]:
        return None
    return (topic["count"] - 1) / (topic["end"] - topic["start"])


def _topic_entry(channel: Channel, schema: Schema | None) -> dict:
    return {"topic": channel.topic, "schema": schema.name if schema else "",
            "schema_encoding": schema.encoding if schema else "",
            "message_encoding": channel.message_encoding, "count": 0, "start": None,
            "end": None, "fields": []}


def _merge(entries: dict[str, dict], channel: Channel, schema: Schema | None, count: int,
           span: tuple[int, int] | None) -> dict:
    entry = entries.setdefault(channel.topic, _topic_entry(channel, schema))
    entry["count"] += count
    if span is not None:
        lo, hi = span[0] / NS, span[1] / NS
        entry["start"] = lo if entry["start"] is None else min(entry["start"], lo)
        entry["end"] = hi if entry["end"] is None else max(entry["end"], hi)
    return entry


def _inspect_indexed(f: BinaryIO, summary: Summary) -> list[dict]:
    entries: dict[str, dict] = {}
    counts = summary.statistics.channel_message_counts if summary.statistics else {}
    for cid, channel in sorted(summary.channels.items()):
        schema = summary.schemas.get(channel.schema_id)
        span = _quietly(lambda c=cid: _channel_span(f, summary, c))
        _merge(entries, channel, schema, counts.get(cid, 0), span)
    for topic, entry in entries.items():
        ids = {cid for cid, c in summary.channels.items() if c.topic == topic}
        first = _quietly(lambda i=ids: _first_message(f, summary, i)) if entry["count"] else None
        if first is not None:
            channel = summary.channels[first[0]]
            entry["fields"] = _fields_of(summary.schemas.get(channel.schema_id), channel,
                                         first[1])
    return list(entries.values())


def _quietly(read: Callable[[], Any]) -> Any:
    """``read()``, or None when a damaged part of the file makes it fail (inspect shows
    what it can)."""
    try:
        return read()
    except Exception:  # whatever a damaged chunk or index makes the reader raise
        return None


def _first_message(f: BinaryIO, summary: Summary, ids: set[int]) -> tuple[int, bytes] | None:
    """(channel id, payload) of the first message of these channels, from one chunk."""
    found: list[tuple[int, bytes]] = []
    handlers = {cid: (lambda t, data, c=cid: found.append((c, data))) for cid in ids}
    for index in _chunks_for(summary, ids):
        _chunk_messages(_chunk_records(f, index), handlers)
        if found:
            return found[0]
    return None


def _channel_span(f: BinaryIO, summary: Summary, cid: int) -> tuple[int, int] | None:
    """First and last log time of a channel, from the message indexes of (usually) only
    its first and last chunk."""
    chunks = [c for c in summary.chunk_indexes if cid in c.message_index_offsets]
    if not chunks:
        return None

    def times(c: ChunkIndex) -> list[int]:
        f.seek(c.message_index_offsets[cid])
        record = next(StreamReader(f, skip_magic=True).records)
        return [t for t, _ in record.records] if isinstance(record, MessageIndex) else []

    lo = hi = None
    for c in sorted(chunks, key=lambda c: c.message_start_time):
        if lo is not None and c.message_start_time >= lo:
            break
        lo = min([*times(c), *([lo] if lo is not None else [])], default=lo)
    for c in sorted(chunks, key=lambda c: -c.message_end_time):
        if hi is not None and c.message_end_time <= hi:
            break
        hi = max([*times(c), *([hi] if hi is not None else [])], default=hi)
    return None if lo is None or hi is None else (lo, hi)


def _fields_of(schema: Schema | None, channel: Channel, data: bytes) -> list[str]:
    """Numeric field paths of one message (empty if it cannot be decoded)."""
    for factory in decoder_factories():
        try:
            decode = factory.decoder_for(channel.message_encoding, schema)
            if decode is not None:
                return numeric_paths(decode(data))
        except Exception:  # inspect lists what it can; undecodable topics show no fields
            return []
    return []


def _inspect_scan(f: BinaryIO, path: Path, problem: str | None) -> tuple[list[dict], list[str]]:
    entries: dict[str, dict] = {}
    channels: dict[int, Channel] = {}
    firsts: dict[str, tuple[Schema | None, Channel, bytes]] = {}
    notes = [problem] if problem else []

    def scan() -> None:
        for schema, channel, message in _scan(f, None, channels):
            entry = _merge(entries, channel, schema, 1, (message.log_time, message.log_time))
            if entry["count"] == 1:
                firsts[channel.topic] = (schema, channel, message.data)

    damage = _guarded(scan)
    if damage:
        notes.append(f"part of the file is damaged or cut off ({damage}); the "
                     "counts cover its readable part")
    for channel in channels.values():
        _merge(entries, channel, None, 0, None)
    for topic, item in firsts.items():
        entries[topic]["fields"] = _fields_of(*item)
    return list(entries.values()), notes


def format_inspect(info: dict) -> Table:
    """A rich table of :func:`inspect_mcap`'s result, for ``pipeline inspect``."""
    from rich.table import Table

    span = (f"{info['duration']:.6g} s from unix time {info['start']:.3f}"
            if info["duration"] is not None else "no messages")
    table = Table(title=f"{info['path']}: {info['message_count']} messages, {span}",
                  caption="\n".join(info["notes"]) or None, caption_justify="left")
    fold = {"overflow": "fold"}
    for col, kw in (("topic", fold), ("type", fold), ("encoding", {}),
                    ("messages", {"justify": "right"}), ("rate (Hz)", {"justify": "right"}),
                    ("numeric fields", fold)):
        table.add_column(col, **kw)
    for t in info["topics"]:
        fields = t["fields"]
        shown = "\n".join(fields[:12]) + (f"\n... (+{len(fields) - 12})"
                                           if len(fields) > 12 else "")
        table.add_row(t["topic"], t["schema"] or "-", t["message_encoding"], str(t["count"]),
                      f"{t['rate_hz']:.3g}" if t["rate_hz"] else "-", shown or "-")
    return table
