"""Decoding MCAP messages: field paths, the library decoders, the handlers and the stamps.

A channel's handler (:func:`make_handler`) decodes each message by the channel's message
encoding (ROS 2 CDR, protobuf, JSON: see the package docstring), reads each signal's field
and, when asked, its stamp, and appends them to the signal's :class:`Series` buffers;
``std_msgs`` scalars take a fast path straight from the CDR bytes.
"""

from __future__ import annotations

import json
import math
import re
import struct
from array import array
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from mcap.decoder import DecoderFactory
from mcap.records import Channel, Schema
from mcap_protobuf.decoder import DecoderFactory as ProtobufDecoderFactory
from mcap_ros2.decoder import DecoderFactory as Ros2DecoderFactory

from ...errors import UserError

NS = 1_000_000_000

# -- field paths ------------------------------------------------------------------------

_NAME = r"[^.\[\]\s:]+"
PATH_RE = re.compile(rf"{_NAME}(?:\[\d+\])*(?:\.{_NAME}(?:\[\d+\])*)*")
_TOKEN_RE = re.compile(rf"({_NAME})|\[(\d+)\]")

FieldPath = tuple[str | int, ...]


SIGNAL_FORMS = "e.g. '/lamp/cmd:data' or '/plate/temp:temperature.value'"


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
    if not sep or not topic or not PATH_RE.fullmatch(fld):
        raise UserError(
            f"signal '{text}': expected TOPIC:FIELD, {SIGNAL_FORMS} (FIELD: dotted names, "
            "array elements as [index])")
    return Signal(topic, fld)


def parse_path(text: str) -> FieldPath:
    """``"a.b[2].c"`` -> ``("a", "b", 2, "c")``; ``ValueError`` when malformed."""
    if not PATH_RE.fullmatch(text):
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
class Series:
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
class Context:
    """What the handlers need to know to read and to explain a failure."""

    path: str
    stamp: FieldPath | None
    stamp_text: str | None
    factories: list[DecoderFactory]

    def error(self, series: Series, what: str) -> UserError:
        sig = series.signal
        return UserError(f"{self.path}: topic '{sig.topic}' field '{sig.field}' "
                         f"({series.role}): {what}")


Handler = Callable[[int, bytes], None]  # (log time in ns, message payload)


def make_handler(ctx: Context, schema: Schema | None, channel: Channel,
                  series: list[Series]) -> Handler:
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


def _decoding_handler(ctx: Context, schema: Schema | None, channel: Channel,
                      series: list[Series]) -> Handler:
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


def _cdr_scalar_handler(series: list[Series], fmt: str, generic: Handler) -> Handler:
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


def _decoder(ctx: Context, schema: Schema | None, channel: Channel,
             series: Series) -> Callable[[bytes], Any]:
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


def _extractor(ctx: Context, series: Series) -> Callable[[Any, int], None]:
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


def _stamp_reader(ctx: Context, series: Series) -> Callable[[Any, int], int] | None:
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


def _stamp_converter(ctx: Context, series: Series, sample: Any) -> Callable[[Any], int]:
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

