"""``pipeline inspect``: what an MCAP log holds, from its summary or one sequential scan."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any, BinaryIO

from mcap.records import Channel, ChunkIndex, MessageIndex, Schema
from mcap.stream_reader import StreamReader
from mcap.summary import Summary

from .decode import NS, decoder_factories, numeric_paths
from .reader import (
    chunk_messages,
    chunk_records,
    chunks_for,
    guarded,
    indexed_summary,
    open_mcap,
    scan_messages,
    seeking_reader,
)

if TYPE_CHECKING:
    from rich.table import Table


def inspect_mcap(path: str | Path) -> dict:
    """What a log holds: per topic the schema, encodings, message count, time span (unix
    seconds) and the numeric field paths of its first message; plus file-level notes.

    Uses the summary (statistics, chunk and message indexes) when present; otherwise one
    sequential scan.
    """
    path = Path(path)
    with open_mcap(path) as f:
        reader = seeking_reader(f, path)
        summary, problem = indexed_summary(reader)
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
    for index in chunks_for(summary, ids):
        chunk_messages(chunk_records(f, index), handlers)
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

    damaged: list[str] = []

    def scan() -> None:
        for schema, channel, message in scan_messages(f, None, channels, damaged):
            entry = _merge(entries, channel, schema, 1, (message.log_time, message.log_time))
            if entry["count"] == 1:
                firsts[channel.topic] = (schema, channel, message.data)

    cut = guarded(scan)
    damage = "; ".join(damaged[:3] + ([cut] if cut else []))
    if damage:
        notes.append(f"part of the file is damaged or cut off ({damage}); the "
                     "counts cover its readable part")
    for channel in channels.values():
        _merge(entries, channel, None, 0, None)
    for topic, item in firsts.items():
        entries[topic]["fields"] = _fields_of(*item)
    return list(entries.values()), notes


def format_inspect(info: dict) -> Table:
    """A rich table of :func:`inspect_mcap`'s result, for ``pipeline inspect``; the file's
    own text (topics, schema and field names) as plain text: no rich markup, control
    characters shown as escapes (:func:`pipeline.quoting.printable`)."""
    from rich.table import Table
    from rich.text import Text

    from ...quoting import printable

    def plain(text: str) -> Text:
        return Text(printable(text, lines=True))

    span = (f"{info['duration']:.6g} s from unix time {info['start']:.3f}"
            if info["duration"] is not None else "no messages")
    table = Table(title=plain(f"{info['path']}: {info['message_count']} messages, {span}"),
                  caption=plain("\n".join(info["notes"])) if info["notes"] else None,
                  caption_justify="left")
    fold = {"overflow": "fold"}
    for col, kw in (("topic", fold), ("type", fold), ("encoding", {}),
                    ("messages", {"justify": "right"}), ("rate (Hz)", {"justify": "right"}),
                    ("numeric fields", fold)):
        table.add_column(col, **kw)
    for t in info["topics"]:
        fields = t["fields"]
        shown = "\n".join(fields[:12]) + (f"\n... (+{len(fields) - 12})"
                                           if len(fields) > 12 else "")
        table.add_row(plain(t["topic"]), plain(t["schema"] or "-"),
                      plain(t["message_encoding"]), str(t["count"]),
                      f"{t['rate_hz']:.3g}" if t["rate_hz"] else "-", plain(shown or "-"))
    return table
