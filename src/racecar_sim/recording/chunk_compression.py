"""An MCAP writer's chunks compressed at a zstd level of our choice, with one compressor kept for the whole file.

mcap's Writer (mcap 1.6.0, the pinned version) compresses each chunk it closes with ``zstandard.compress(data)``:
level 3, with a new compressor per chunk. A run's chunks hold JPEG camera images, which zstd cannot shrink, and
scans and link states, which it can. On a main job's run.mcap (20 sim s, 29.6 MB of chunks) level 1 took 64 ms
where level 3 took 159 ms, for 2 % more bytes (13.34 MB against 13.05 MB): the writer process's CPU is what a
recording costs the simulation on a small machine, and a file 2 % larger costs nobody a core.

:func:`compress_chunks` gives a writer its own chunk finalizer: the steps of mcap 1.6.0's, in the same order, with
the compressor swapped. Messages, indexes and the summary are the bytes mcap writes; only the compressed form of each
chunk differs, and every reader decompresses it to the same bytes (at level 3 the whole file is mcap's, byte for
byte: tests/test_mcap_chunk_messages.py).
"""

from __future__ import annotations

import zlib
from typing import Any

import zstandard
from mcap.records import Chunk, ChunkIndex
from mcap.writer import CompressionType, IndexType, Writer

ZSTD_LEVEL = 1
"""The level of a recording's chunks (mcap's own is 3)."""
_PRIVATE = "_Writer__"  # the Writer's name-mangled private attributes
_STATE = ("chunk_builder", "statistics", "compression", "enable_crcs", "stream", "record_builder", "index_types")


def compress_chunks(writer: Writer, level: int = ZSTD_LEVEL) -> bool:
    """Make `writer` compress its chunks with zstd at `level`; whether it did. A writer that does not compress with
    zstd, or whose private state is not mcap 1.6.0's, is left as it is."""
    state = {name: getattr(writer, _PRIVATE + name, None) for name in _STATE}
    if state["compression"] != CompressionType.ZSTD or state["chunk_builder"] is None:
        return False
    needed = ("chunk_indices", "flush", "finalize_chunk")
    if any(value is None for value in state.values()) or not all(hasattr(writer, _PRIVATE + n) for n in needed):
        return False
    compressor = zstandard.ZstdCompressor(level=level)
    # the Writer calls self.__finalize_chunk(): an instance attribute of that name is the one it finds
    setattr(writer, _PRIVATE + "finalize_chunk", lambda: _finalize_chunk(writer, compressor.compress))
    return True


def _finalize_chunk(writer: Writer, compress: Any) -> None:
    """mcap 1.6.0's Writer.__finalize_chunk, zstd by `compress`: write the chunk in progress (if it holds a message),
    then its message indexes, and keep its chunk index for the summary."""
    get = writer.__getattribute__
    builder = get(_PRIVATE + "chunk_builder")
    if builder.num_messages == 0:
        return
    get(_PRIVATE + "statistics").chunk_count += 1
    chunk_data = builder.end()
    compressed = compress(chunk_data)
    chunk = Chunk(
        compression="zstd",
        data=compressed,
        message_start_time=builder.message_start_time,
        message_end_time=builder.message_end_time,
        uncompressed_crc=zlib.crc32(chunk_data) if get(_PRIVATE + "enable_crcs") else 0,
        uncompressed_size=len(chunk_data),
    )
    flush, stream, records = get(_PRIVATE + "flush"), get(_PRIVATE + "stream"), get(_PRIVATE + "record_builder")
    flush()
    chunk_start = stream.tell()
    chunk.write(records)
    index = ChunkIndex(
        message_start_time=chunk.message_start_time,
        message_end_time=chunk.message_end_time,
        chunk_start_offset=chunk_start,
        chunk_length=records.count,
        message_index_offsets={},
        message_index_length=0,
        compression=chunk.compression,
        compressed_size=len(compressed),
        uncompressed_size=chunk.uncompressed_size,
    )
    flush()
    indexes_start = stream.tell()
    if get(_PRIVATE + "index_types") & IndexType.MESSAGE:
        offsets: dict[int, int] = index.message_index_offsets
        for channel_id, message_index in builder.message_indices.items():
            offsets[channel_id] = indexes_start + records.count
            message_index.write(records)
    index.message_index_length = records.count
    flush()
    get(_PRIVATE + "chunk_indices").append(index)  # read now: spill_chunk_indexes may have replaced the list
    builder.reset()
