"""An MCAP writer's chunk indexes kept in a temporary file until the summary is written, so that a recording's memory
stays flat however long it runs.

mcap's Writer (mcap 1.6.0, the pinned version) keeps one ChunkIndex per chunk in a list until finish() writes them
all into the file's summary section. Each holds a dict of the chunk's channels: about 7 KB in a 4-car run, which
closes 3 chunks a sim second (20 MB per 1000 sim s). SpilledChunkIndexes takes the list's place: each index is
serialized as it comes, into the very record finish() would write, in an unnamed temporary file (about 1 KB a
chunk: a thousandth of the recording), and finish() copies the records back one at a time. The file is byte for
byte the one the list gives.
"""

from __future__ import annotations

import contextlib
import os
import stat
import struct
import tempfile
from collections.abc import Iterator
from typing import BinaryIO

from mcap.data_stream import RecordBuilder
from mcap.records import ChunkIndex
from mcap.writer import Writer

_HEADER = struct.Struct("<BQ")  # a record's opcode and length
_ATTRIBUTE = "_Writer__chunk_indices"  # the Writer's list (a name-mangled private attribute)


class _Record:
    """A record already serialized: write() puts its bytes into finish()'s summary builder, as ChunkIndex.write."""

    __slots__ = ("data",)

    def __init__(self, data: bytes) -> None:
        self.data = data

    def write(self, builder: RecordBuilder) -> None:
        builder.write(self.data)


class SpilledChunkIndexes:
    """A Writer's list of chunk indexes, as the Writer uses it (append() per chunk, one pass at finish()), in `file`."""

    def __init__(self, file: BinaryIO) -> None:
        self._file = file
        self._builder = RecordBuilder()
        self._count = 0

    def append(self, index: ChunkIndex) -> None:
        """Serialize `index` to the end of the file."""
        index.write(self._builder)
        self._file.write(self._builder.end())
        self._count += 1

    def __len__(self) -> int:
        return self._count

    def __iter__(self) -> Iterator[_Record]:
        """The indexes appended, in order, each as its serialized record: finish()'s one pass, after which the
        temporary file is deleted."""
        self._file.flush()
        self._file.seek(0)
        for _ in range(self._count):
            head = self._file.read(_HEADER.size)
            yield _Record(head + self._file.read(_HEADER.unpack(head)[1]))
        self.close()

    def close(self) -> None:
        """Delete the temporary file (unnamed: the file system frees it at the latest when the process ends)."""
        self._file.close()


def spill_chunk_indexes(writer: Writer, path: str | os.PathLike[str], stream: BinaryIO) -> SpilledChunkIndexes | None:
    """Put a SpilledChunkIndexes in the place of `writer`'s list of chunk indexes (still empty: before the first
    message). Its file goes in the recording's folder (`path`) when `stream` is a regular file, on the disk the
    recording's bytes go to, else in the temporary folder. None, and the list left in place, where no temporary file
    can be made or the Writer keeps no such list (another mcap version)."""
    indexes = getattr(writer, _ATTRIBUTE, None)
    if not isinstance(indexes, list) or indexes:
        return None
    folders: list[str | None] = [None]
    with contextlib.suppress(OSError, ValueError, AttributeError):
        if stat.S_ISREG(os.fstat(stream.fileno()).st_mode):
            folders.insert(0, os.path.dirname(os.path.abspath(os.fspath(path))))
    for folder in folders:
        try:
            file = tempfile.TemporaryFile(prefix=".mcap-chunk-indexes-", dir=folder)
        except OSError:
            continue
        spilled = SpilledChunkIndexes(file)
        setattr(writer, _ATTRIBUTE, spilled)
        return spilled
    return None
