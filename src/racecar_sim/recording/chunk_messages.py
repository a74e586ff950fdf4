"""Messages put straight into an MCAP writer's chunk: the bytes ``Writer.add_message`` writes, at a third of its cost.

mcap's Writer (mcap 1.6.0, the pinned version) makes a ``Message`` record object per message, writes it into the
chunk's BytesIO field by field (a placeholder length, then a seek back to fill it in) and updates the file's
statistics and the chunk's message index. A 4-car run records about 4400 messages a sim second, and that Python was
most of the writer's work. :class:`ChunkMessages` does the same updates and writes the same record (opcode, length,
channel, sequence, log and publish time, data) with one ``struct.pack``; it closes a full chunk as the Writer does,
and a chunk's message indexes are written with one ``struct.pack`` each.
The file is byte for byte the one ``add_message`` gives (tests/test_mcap_chunk_messages.py).
"""

from __future__ import annotations

import struct
from collections.abc import Callable
from itertools import chain
from typing import Any

from mcap.data_stream import RecordBuilder
from mcap.opcode import Opcode
from mcap.records import MessageIndex
from mcap.writer import Writer

MESSAGE_RECORD = struct.Struct("<BQHIQQ")  # opcode 0x05, record length, channel id, sequence, log time, publish time
MESSAGE_OPCODE = 0x05
MESSAGE_FIXED = MESSAGE_RECORD.size - 9  # the record's bytes before its data, opcode and length left out
# the Writer's private state this reads and updates (name-mangled attributes)
_CHUNK_BUILDER, _STATISTICS, _CHUNK_SIZE = "_Writer__chunk_builder", "_Writer__statistics", "_Writer__chunk_size"
_FINALIZE = "_Writer__finalize_chunk"
_INDEX_HEAD = struct.Struct("<BQHI")  # opcode 0x07, record length, channel id, the entries' byte length


class ChunkIndex(MessageIndex):
    """A chunk's message index of one channel that writes its (log time, offset) entries with one struct.pack, not
    two writes each: the bytes MessageIndex.write gives."""

    def write(self, stream: RecordBuilder) -> None:
        size = 16 * len(self.records)
        stream.write(_INDEX_HEAD.pack(Opcode.MESSAGE_INDEX, 6 + size, self.channel_id, size))
        stream.write(struct.pack(f"<{2 * len(self.records)}Q", *chain.from_iterable(self.records)))


class ChunkMessages:
    """Adds messages to `writer`'s chunk in progress as ``writer.add_message`` would; see the module docstring.

    Build it with :meth:`of`, which gives None where the writer is not one this knows (another mcap version, a writer
    without chunks): then ``add_message`` it is.
    """

    def __init__(self, writer: Writer) -> None:
        self._writer = writer
        # the writer's chunk in progress, its statistics, its chunk size and how it closes a chunk (McapRecorder's
        # write_many makes add()'s updates inline)
        self.builder: Any = getattr(writer, _CHUNK_BUILDER)
        self.statistics: Any = getattr(writer, _STATISTICS)
        self.chunk_size: int = getattr(writer, _CHUNK_SIZE)
        self.finalize: Callable[[], None] = getattr(writer, _FINALIZE)

    @classmethod
    def of(cls, writer: Writer) -> ChunkMessages | None:
        """A ChunkMessages of `writer`, or None where its private state is not what mcap 1.6.0 keeps."""
        builder = getattr(writer, _CHUNK_BUILDER, None)
        statistics = getattr(writer, _STATISTICS, None)
        needed = (
            (builder, ("num_messages", "message_start_time", "message_end_time", "message_indices", "record_writer")),
            (statistics, ("message_count", "message_start_time", "message_end_time", "channel_message_counts")),
        )
        if builder is None or statistics is None or not isinstance(getattr(writer, _CHUNK_SIZE, None), int):
            return None
        if not callable(getattr(writer, _FINALIZE, None)):
            return None
        if any(not hasattr(owner, name) for owner, names in needed for name in names):
            return None
        if not hasattr(builder.record_writer, "_buffer"):
            return None
        return cls(writer)

    def add(self, channel_id: int, log_time: int, data: bytes, publish_time: int, sequence: int) -> bool:
        """Add one message; whether that closed the chunk (written to the stream, as add_message's would be)."""
        statistics = self.statistics
        if statistics.message_count == 0:
            statistics.message_start_time = log_time
        elif log_time < statistics.message_start_time:
            statistics.message_start_time = log_time
        if log_time > statistics.message_end_time:
            statistics.message_end_time = log_time
        statistics.channel_message_counts[channel_id] += 1
        statistics.message_count += 1
        builder = self.builder
        if builder.num_messages == 0:
            builder.message_start_time = log_time
        elif log_time < builder.message_start_time:
            builder.message_start_time = log_time
        if log_time > builder.message_end_time:
            builder.message_end_time = log_time
        buffer = builder.record_writer._buffer
        offset = buffer.tell()
        index = builder.message_indices.get(channel_id)
        if index is None:
            index = builder.message_indices[channel_id] = ChunkIndex(channel_id=channel_id, records=[])
        index.records.append((log_time, offset))
        builder.num_messages += 1
        buffer.write(
            MESSAGE_RECORD.pack(MESSAGE_OPCODE, MESSAGE_FIXED + len(data), channel_id, sequence, log_time, publish_time)
        )
        buffer.write(data)
        if buffer.tell() > self.chunk_size:
            self.finalize()
            return True
        return False
