"""Reading an MCAP file: the summary, the chunk index walk, record framing, the unindexed scan.

Reading
    Through the summary's chunk index, only the chunks whose message index lists the two
    topics are read, one at a time (decompressed and CRC-checked with mcap's record
    classes); inside a chunk the records are walked with ``struct`` and only the wanted
    channels' payloads are copied. Values go straight into ``array('d')`` buffers, so
    memory follows the selected signals, not the file size. ``std_msgs`` scalars
    (``Float64`` ...) are unpacked from the CDR bytes; everything else goes through the
    library decoders. A file without a summary or chunk index (a log cut off by a crash)
    is read by a sequential scan with mcap's ``StreamReader``, with a note, each chunk's
    CRC checked there too; a file that ends in the middle of a record keeps the complete
    part before it, and a damaged chunk is skipped, with a note (and the gap it leaves is
    reported as a gap).
"""

from __future__ import annotations

import struct
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import TYPE_CHECKING, BinaryIO

from mcap.data_stream import ReadDataStream
from mcap.exceptions import EndOfFile, McapError, UnsupportedCompressionError
from mcap.reader import SeekingReader
from mcap.records import Channel, Chunk, ChunkIndex, Message, Schema
from mcap.stream_reader import StreamReader, breakup_chunk, get_chunk_data_stream
from mcap.summary import Summary

from ...errors import UserError
from .decode import (
    Context,
    FieldPath,
    Handler,
    Series,
    decoder_factories,
    make_handler,
    parse_path,
)

if TYPE_CHECKING:
    from .decode import Signal


def open_mcap(path: Path) -> BinaryIO:
    try:
        return open(path, "rb")
    except OSError as exc:
        raise UserError(f"{path}: cannot open ({exc.strerror}); expected a readable MCAP "
                        "file") from None


def seeking_reader(f: BinaryIO, path: Path) -> SeekingReader:
    try:
        return SeekingReader(f)
    except (McapError, struct.error, EOFError) as exc:
        raise UserError(f"{path}: not an MCAP file ({type(exc).__name__}); expected an "
                        "MCAP log starting with the MCAP magic bytes") from None


def indexed_summary(reader: SeekingReader) -> tuple[Summary | None, str | None]:
    """The summary when it has a chunk index, else ``None`` and the reason (a note)."""
    try:
        summary = reader.get_summary()
    except Exception:  # whatever a missing or damaged footer makes the reader raise
        return None, ("no summary or index at the end of the file (a log cut "
                      "off, e.g. by a crash?); read by a sequential scan")
    if summary is None or not summary.chunk_indexes:
        return None, "the file has no chunk index; read by a sequential scan"
    return summary, None


def scan_messages(f: BinaryIO, topics: set[str] | None, channels: dict[int, Channel],
                  damaged: list[str] | None = None
                  ) -> Iterator[tuple[Schema | None, Channel, Message]]:
    """Sequential scan with mcap's StreamReader; ``channels`` collects what it sees. Each
    chunk is decompressed and its CRC checked on its own (:func:`_scanned_records`): a
    chunk that fails is skipped and described in ``damaged``, the scan goes on."""
    f.seek(0)
    schemas: dict[int, Schema] = {}
    for record in _scanned_records(f, [] if damaged is None else damaged):
        if isinstance(record, Message):
            channel = channels.get(record.channel_id)
            if channel is not None and (topics is None or channel.topic in topics):
                yield schemas.get(channel.schema_id), channel, record
        elif isinstance(record, Channel):
            channels[record.id] = record
        elif isinstance(record, Schema):
            schemas[record.id] = record


def _scanned_records(f: BinaryIO, damaged: list[str]) -> Iterator[object]:
    """The records of a file read front to back, each chunk's inner records after its CRC
    check (mcap's reader checks none on a scan unless asked, and then stops at the first
    bad chunk): a bit flipped in a chunk of a log cut off by a crash would otherwise be
    read as data (36.0 became 2e-307). A chunk whose CRC does not match, or whose records
    do not parse, is skipped and described in ``damaged``; a file cut off in a record
    ends the scan (the reader raises, and :func:`guarded` keeps what was read)."""
    n = 0
    for record in StreamReader(f, emit_chunks=True).records:
        if not isinstance(record, Chunk):
            yield record
            continue
        n += 1
        try:
            inner = breakup_chunk(record, validate_crc=True)
        except UnsupportedCompressionError as exc:
            raise UserError(f"{getattr(f, 'name', 'the log')}: chunk {n} is compressed "
                            f"with {exc}, which this installation "
                            "cannot read; expected zstd, lz4 or no compression (install "
                            "the zstandard and lz4 packages)") from None
        except Exception as exc:  # whatever a damaged chunk makes the reader raise
            damaged.append(f"chunk {n} from the start: {_damage_text(exc)}")
            # its schemas and channels, when they still parse, name the topics of the
            # chunks after it; its messages are not used
            yield from _definitions(record)
            continue
        yield from inner


def _definitions(chunk: Chunk) -> list[object]:
    """The Schema and Channel records of a chunk that failed its CRC, read without the
    check (none when even they do not parse): a log writes a topic's channel once, in
    the first chunk that has its messages, so losing it would lose the topic."""
    try:
        records = breakup_chunk(chunk, validate_crc=False)
    except Exception:  # whatever the damage makes the parser raise
        return []
    return [r for r in records if isinstance(r, Schema | Channel)]


_RECORD = struct.Struct("<BQ")  # MCAP record framing: opcode, length
_MESSAGE = struct.Struct("<HIQ")  # Message record: channel id, sequence, log time, ...
_MESSAGE_OPCODE = 0x05
_MESSAGE_DATA = 22  # channel id (2) + sequence (4) + log time (8) + publish time (8)


def chunks_for(summary: Summary, channel_ids: set[int]) -> list[ChunkIndex]:
    """The chunks that may hold these channels (all, where a chunk has no message
    index), in log-time order."""
    chunks = [c for c in summary.chunk_indexes
              if not c.message_index_offsets or channel_ids & c.message_index_offsets.keys()]
    return sorted(chunks, key=lambda c: (c.message_start_time, c.chunk_start_offset))


def chunk_records(f: BinaryIO, index: ChunkIndex) -> bytes:
    """The decompressed records of one chunk, read with mcap's record classes (its CRC
    checked, when the writer stored one)."""
    f.seek(index.chunk_start_offset + 9)  # past the opcode (1) and the length (8)
    stream, size = get_chunk_data_stream(Chunk.read(ReadDataStream(f)), validate_crc=True)
    return stream.read(size)


def chunk_messages(data: bytes, handlers: dict[int, Handler]) -> None:
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


def _read_indexed(f: BinaryIO, summary: Summary, ctx: Context,
                  by_topic: dict[str, list[Series]]) -> str | None:
    """Read only the chunks that hold the signals' channels, one chunk at a time; a
    damaged chunk is skipped (the complete messages before the damage are kept) and
    described in the returned text."""
    handlers = {cid: make_handler(ctx, summary.schemas.get(c.schema_id), c, by_topic[c.topic])
                for cid, c in summary.channels.items() if c.topic in by_topic}
    damaged: list[str] = []
    for index in chunks_for(summary, set(handlers)):
        problem = guarded(lambda i=index: chunk_messages(chunk_records(f, i), handlers))
        if problem is not None:
            damaged.append(f"chunk at byte {index.chunk_start_offset}: {problem}")
    if not damaged:
        return None
    more = f"; and {len(damaged) - 3} more damaged chunks" if len(damaged) > 3 else ""
    return "; ".join(damaged[:3]) + more


def _read_scan(f: BinaryIO, ctx: Context, by_topic: dict[str, list[Series]],
               channels: dict[int, Channel], damaged: list[str]) -> None:
    """Read a file without a chunk index by one sequential scan (damaged chunks skipped,
    described in ``damaged``)."""
    handlers: dict[int, Handler] = {}
    for schema, channel, message in scan_messages(f, set(by_topic), channels, damaged):
        handler = handlers.get(channel.id)
        if handler is None:
            handler = make_handler(ctx, schema, channel, by_topic[channel.topic])
            handlers[channel.id] = handler
        handler(message.log_time, message.data)


def guarded(read: Callable[[], None]) -> str | None:
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


def read_series(path: Path, signals: list[tuple[str, Signal]], stamp: str | None
                 ) -> tuple[list[Series], dict[int, Channel], list[str], str | None]:
    """Read the signals' messages: series, the channels known, notes, damage text."""
    ctx = Context(str(path), _stamp_path(stamp, path), stamp, decoder_factories())
    series = [Series(sig, role) for role, sig in signals]
    by_topic: dict[str, list[Series]] = {}
    for s in series:
        by_topic.setdefault(s.signal.topic, []).append(s)
    with open_mcap(path) as f:
        summary, problem = indexed_summary(seeking_reader(f, path))
        if summary is not None:
            channels = dict(summary.channels)
            check_topics(ctx, series, channels, summary)
            damage = _read_indexed(f, summary, ctx, by_topic)
            return series, channels, [], damage
        channels: dict[int, Channel] = {}
        damaged: list[str] = []
        cut = guarded(lambda: _read_scan(f, ctx, by_topic, channels, damaged))
    parts = damaged[:3] + ([f"and {len(damaged) - 3} more damaged chunks"]
                           if len(damaged) > 3 else []) + ([cut] if cut else [])
    return series, channels, [problem or ""], "; ".join(parts) or None


def _stamp_path(stamp: str | None, path: Path) -> FieldPath | None:
    if stamp is None:
        return None
    try:
        return parse_path(stamp)
    except ValueError:
        raise UserError(f"{path}: stamp '{stamp}' is not a field path; expected e.g. "
                        "'header.stamp'") from None


def check_topics(ctx: Context, series: list[Series], channels: dict[int, Channel],
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

