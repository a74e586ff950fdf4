"""Recovery of an MCAP file that has no summary or footer (a recording killed by SIGKILL, power loss, OOM).

The file is read record by record from the start, as ``mcap recover`` and ``ros2 bag reindex`` do, until
the first record that is truncated or corrupt: the header, schemas, channels (with their metadata),
metadata and attachment records, loose messages, and every chunk whose compressed data is complete,
decompresses and matches its CRC. Those records are rewritten, messages in log-time order, to a new
file with the same profile, a summary and a footer. What follows the first unreadable record is
reported as lost, in bytes.
"""

from __future__ import annotations

import heapq
import io
import os
import struct
import zlib
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO, Any

from mcap.data_stream import ReadDataStream
from mcap.exceptions import EndOfFile, McapError
from mcap.opcode import Opcode
from mcap.records import Attachment, Channel, Chunk, Footer, Header, McapRecord, Message, Metadata, Schema
from mcap.writer import CompressionType, Writer

from racecar_sim.core.errors import RecordingError

MAGIC = b"\x89MCAP0\r\n"
_RECORD_HEADER = struct.Struct("<BQ")  # opcode, length of the body


@dataclass
class Recovery:
    """What :func:`recover_mcap` read and wrote.

    ``messages`` and ``channels`` count what the output holds; ``start_ns`` / ``end_ns`` are the first
    and last log times (``None`` with no message). ``intact_bytes`` of the input's ``size`` were read;
    the rest (``lost_bytes``) begins with the record ``stopped_at`` describes. ``complete`` is true when
    the input already had its summary, footer and closing magic.
    """

    source: Path
    output: Path
    size: int
    intact_bytes: int
    complete: bool
    messages: int = 0
    channels: int = 0
    start_ns: int | None = None
    end_ns: int | None = None
    counts: dict[str, int] = field(default_factory=dict)
    stopped_at: str = ""

    @property
    def lost_bytes(self) -> int:
        return self.size - self.intact_bytes

    def summary(self) -> str:
        """One line: messages, channels, log-time span, and what could not be read."""
        if self.start_ns is None or self.end_ns is None:
            span = "no log time"
        else:
            span = f"log time {self.start_ns / 1e9:.3f} s to {self.end_ns / 1e9:.3f} s"
        if self.complete:
            tail = f"{self.source} was complete"
        elif self.lost_bytes:
            tail = f"the last {self.lost_bytes} bytes of {self.source} could not be read ({self.stopped_at})"
        else:
            tail = f"{self.source} ended after its last intact record, without a footer (0 bytes unread)"
        return f"{self.output}: {self.messages} messages on {self.channels} channels, {span}; {tail}"


def default_output(source: str | os.PathLike[str]) -> Path:
    """``run.mcap`` -> ``run.recovered.mcap`` beside it (any other name gets ``.recovered.mcap`` appended)."""
    path = Path(source)
    stem = path.stem if path.suffix == ".mcap" else path.name
    return path.with_name(f"{stem}.recovered.mcap")


def recover_mcap(source: str | os.PathLike[str], output: str | os.PathLike[str] | None = None) -> Recovery:
    """Rewrite every intact record of ``source`` into a valid MCAP file ``output``.

    ``output`` defaults to :func:`default_output` (``BROKEN.recovered.mcap`` beside the input). It is
    written to a temporary file beside it and renamed into place at the end, so it may be ``source``
    itself. A file that is already complete is rewritten too (the result says it was complete).

    Raises:
        RecordingError: ``source`` is missing, a directory, unreadable, not MCAP, or its header is
            unreadable; or ``output`` cannot be written. The message is one line naming the file.
    """
    src = Path(source)
    dst = default_output(src) if output is None else Path(output)
    if src.is_dir():
        raise RecordingError(f"{src}: is a directory, not an MCAP file")
    if dst.is_dir():
        raise RecordingError(f"{dst}: is a directory; give the recovered file's name")
    try:
        stream = open(src, "rb")  # closed below
    except OSError as exc:
        raise RecordingError(f"{src}: cannot read it ({_reason(exc)})") from None
    with stream:
        if not os.path.isfile(src):
            raise RecordingError(f"{src}: not a regular file, so not an MCAP file")
        scan = _Scan(stream, src)
        scan.run()
        return _write(scan, dst)


def _reason(exc: OSError) -> str:
    return exc.strerror or str(exc)


@dataclass
class _Source:
    """A chunk or a loose message of the input, to be re-read in log-time order."""

    start_ns: int
    offset: int
    opcode: int
    length: int


class _Strict(ReadDataStream):
    """mcap's record parsers read from this; a short read (a truncated field) raises instead of passing."""

    def read(self, length: int) -> bytes:
        data = super().read(length)
        if len(data) != length:
            raise EndOfFile()
        return data


def _parse(opcode: int, body: bytes) -> Any:
    """The mcap record of ``body``; raises ``ValueError`` when it does not parse."""
    stream = _Strict(io.BytesIO(body))
    try:
        if opcode == Opcode.MESSAGE:
            return Message.read(stream, len(body))
        parsers: dict[int, Callable[[ReadDataStream], McapRecord]] = {
            Opcode.HEADER: Header.read,
            Opcode.SCHEMA: Schema.read,
            Opcode.CHANNEL: Channel.read,
            Opcode.CHUNK: Chunk.read,
            Opcode.METADATA: Metadata.read,
            Opcode.ATTACHMENT: Attachment.read,
            Opcode.FOOTER: Footer.read,
        }
        return parsers[opcode](stream)
    except (EndOfFile, McapError, struct.error, UnicodeDecodeError, KeyError) as exc:
        raise ValueError(f"corrupt {_name(opcode)} record") from exc


def _name(opcode: int) -> str:
    try:
        return Opcode(opcode).name.title().replace("_", "")
    except ValueError:
        return f"opcode 0x{opcode:02x}"


def _chunk_records(chunk: Chunk) -> list[tuple[int, bytes]]:
    """The (opcode, body) records of a chunk; raises ``ValueError`` when it does not decompress or check."""
    try:
        if chunk.compression == "zstd":
            import zstandard

            data = zstandard.ZstdDecompressor().decompress(chunk.data, max_output_size=chunk.uncompressed_size)
        elif chunk.compression == "lz4":
            import lz4.frame

            data = lz4.frame.decompress(chunk.data)
        elif chunk.compression == "":
            data = chunk.data
        else:
            raise ValueError(f"Chunk compressed with unsupported {chunk.compression!r}")
    except ValueError:
        raise
    except Exception as exc:  # zstandard.ZstdError, lz4's RuntimeError, ImportError
        raise ValueError(f"Chunk does not decompress ({exc})") from None
    if len(data) != chunk.uncompressed_size:
        raise ValueError("Chunk decompresses to the wrong size")
    if chunk.uncompressed_crc and zlib.crc32(data) != chunk.uncompressed_crc:
        raise ValueError("Chunk fails its CRC check")
    records = []
    for opcode, _, body in _frames(io.BytesIO(data), len(data)):
        if body is None:
            raise ValueError("Chunk holds a truncated record")
        records.append((opcode, body))
    return records


def _frames(stream: IO[bytes], size: int, start: int = 0) -> Iterator[tuple[int, int, bytes | None]]:
    """(opcode, offset, body) of each record from ``start`` to ``size``; body None: truncated, the last."""
    offset = start
    while offset < size:
        head = stream.read(_RECORD_HEADER.size)
        if len(head) < _RECORD_HEADER.size:
            yield -1, offset, None
            return
        opcode, length = _RECORD_HEADER.unpack(head)
        if length > size - offset - _RECORD_HEADER.size:
            yield opcode, offset, None
            return
        body = stream.read(length)
        if len(body) != length:  # the file shrank while being read
            yield opcode, offset, None
            return
        yield opcode, offset, body
        offset += _RECORD_HEADER.size + length


class _Scan:
    """First pass: what is intact, where the chunks and loose messages are, their schemas and channels."""

    def __init__(self, stream: IO[bytes], path: Path) -> None:
        self.stream, self.path = stream, path
        self.size = os.fstat(stream.fileno()).st_size
        self.header: Header | None = None
        self.schemas: dict[int, Schema] = {}
        self.channels: dict[int, Channel] = {}
        self.extras: list[Metadata | Attachment] = []  # in file order
        self.sources: list[_Source] = []
        self.intact = len(MAGIC)
        self.complete = False
        self.stopped_at = ""

    def run(self) -> None:
        if self.stream.read(len(MAGIC)) != MAGIC:
            raise RecordingError(f"{self.path}: not an MCAP file (it does not start with the MCAP magic)")
        data_end = False
        for opcode, offset, body in _frames(self.stream, self.size, len(MAGIC)):
            if body is None:
                what = f"{_name(opcode)} record" if opcode >= 0 else "record header"
                self.stopped_at = f"a truncated {what} at byte {offset}"
                break
            try:
                if data_end:  # the summary section: its records repeat the data section's
                    if opcode == Opcode.FOOTER:
                        _parse(opcode, body)
                        self.complete = self._closing_magic(offset + _RECORD_HEADER.size + len(body))
                        if not self.complete:
                            self.stopped_at = f"no closing MCAP magic after the Footer at byte {offset}"
                            break
                elif self.header is None:
                    if opcode != Opcode.HEADER:
                        raise ValueError(f"{_name(opcode)} record where the Header should be")
                    self.header = _parse(opcode, body)
                else:
                    data_end = self._data_record(opcode, offset, body)
            except ValueError as exc:
                self.stopped_at = f"{exc} at byte {offset}"
                break
            self.intact = offset + _RECORD_HEADER.size + len(body)
            if self.complete:
                self.intact = self.size
                break
        if self.header is None:
            raise RecordingError(f"{self.path}: the MCAP header is truncated or corrupt, nothing to recover")

    def _closing_magic(self, end: int) -> bool:
        return self.stream.read(len(MAGIC) + 1) == MAGIC and end + len(MAGIC) == self.size

    def _data_record(self, opcode: int, offset: int, body: bytes) -> bool:
        """Take one data-section record in; true at the Data End record."""
        if opcode == 0:
            raise ValueError("an invalid record (opcode 0x00)")
        if opcode == Opcode.DATA_END:
            return True
        if opcode == Opcode.FOOTER:  # a footer with no Data End before it: still the end of the data
            _parse(opcode, body)
            self.complete = self._closing_magic(offset + _RECORD_HEADER.size + len(body))
            if not self.complete:
                raise ValueError("a Footer without the closing MCAP magic")
            return True
        if opcode == Opcode.CHUNK:
            chunk = _parse(opcode, body)
            inner = [self._inner(op, rec) for op, rec in _chunk_records(chunk)]
            times = [t for t in inner if t is not None]
            if times:
                self.sources.append(_Source(min(times), offset, opcode, len(body)))
        elif opcode in (Opcode.SCHEMA, Opcode.CHANNEL):
            self._inner(opcode, body)
        elif opcode == Opcode.MESSAGE:
            log_time = self._inner(opcode, body)
            self.sources.append(_Source(log_time or 0, offset, opcode, len(body)))
        elif opcode in (Opcode.METADATA, Opcode.ATTACHMENT):
            self.extras.append(_parse(opcode, body))
        # Message indexes, and records the spec does not define here or this version does not know: skipped.
        return False

    def _inner(self, opcode: int, body: bytes) -> int | None:
        """A schema, channel or message record (loose or in a chunk); a message's log time."""
        if opcode == Opcode.SCHEMA:
            schema = _parse(opcode, body)
            self.schemas.setdefault(schema.id, schema)
        elif opcode == Opcode.CHANNEL:
            channel = _parse(opcode, body)
            self.channels.setdefault(channel.id, channel)
        elif opcode == Opcode.MESSAGE:
            return int(_parse(opcode, body).log_time)
        return None

    def messages(self, source: _Source) -> Iterator[Message]:
        """Second pass: the messages of one chunk or loose message, read again from the file."""
        self.stream.seek(source.offset + _RECORD_HEADER.size)
        body = self.stream.read(source.length)
        if source.opcode == Opcode.MESSAGE:
            yield _parse(Opcode.MESSAGE, body)
            return
        for opcode, record in _chunk_records(_parse(Opcode.CHUNK, body)):
            if opcode == Opcode.MESSAGE:
                yield _parse(opcode, record)


def _write(scan: _Scan, dst: Path) -> Recovery:
    assert scan.header is not None
    result = Recovery(scan.path, dst, scan.size, scan.intact, scan.complete, stopped_at=scan.stopped_at)
    tmp = dst.with_name(f".{dst.name}.{os.getpid()}.tmp")
    try:
        out = open(tmp, "wb")  # closed below
    except OSError as exc:
        raise RecordingError(f"{dst}: cannot write the recovered file ({_reason(exc)})") from None
    try:
        with out:
            _write_records(scan, out, result)
        os.replace(tmp, dst)
    except OSError as exc:
        tmp.unlink(missing_ok=True)
        raise RecordingError(f"{dst}: cannot write the recovered file ({_reason(exc)})") from None
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    return result


def _write_records(scan: _Scan, out: IO[bytes], result: Recovery) -> None:
    assert scan.header is not None
    writer = Writer(out, compression=CompressionType.ZSTD)
    writer.start(profile=scan.header.profile, library=scan.header.library)
    for record in scan.extras:
        if isinstance(record, Metadata):
            writer.add_metadata(record.name, record.metadata)
        else:
            writer.add_attachment(record.create_time, record.log_time, record.name, record.media_type, record.data)
    schema_ids = {0: 0}
    for schema in scan.schemas.values():
        schema_ids[schema.id] = writer.register_schema(schema.name, schema.encoding, schema.data)
    channel_ids: dict[int, tuple[int, str]] = {}
    for channel in scan.channels.values():
        if channel.schema_id in schema_ids:  # a channel whose schema was lost cannot be decoded: dropped
            new_id = writer.register_channel(
                channel.topic, channel.message_encoding, schema_ids[channel.schema_id], dict(channel.metadata)
            )
            channel_ids[channel.id] = (new_id, channel.topic)
    for message in _in_log_time_order(scan):
        target = channel_ids.get(message.channel_id)
        if target is None:
            continue
        writer.add_message(target[0], message.log_time, message.data, message.publish_time, message.sequence)
        result.messages += 1
        result.counts[target[1]] = result.counts.get(target[1], 0) + 1
        result.start_ns = message.log_time if result.start_ns is None else result.start_ns
        result.end_ns = message.log_time
    writer.finish()
    result.channels = len(channel_ids)


def _in_log_time_order(scan: _Scan) -> Iterator[Message]:
    """Every message of the intact chunks and loose messages by log time; ties keep file order.

    Sources are visited by (first log time, offset); a message waiting in the heap is released once no
    source still to be read can hold an earlier one, so only overlapping chunks are held in memory.
    """
    heap: list[tuple[int, int, int, Message]] = []
    for source in sorted(scan.sources, key=lambda s: (s.start_ns, s.offset)):
        while heap and heap[0][:2] < (source.start_ns, source.offset):
            yield heapq.heappop(heap)[3]
        for index, message in enumerate(scan.messages(source)):
            heapq.heappush(heap, (message.log_time, source.offset, index, message))
    while heap:
        yield heapq.heappop(heap)[3]
