"""MCAP recorder: ROS 2 CDR messages with embedded ``.msg`` schemas, stamped in sim time."""

from __future__ import annotations

import contextlib
import os
import threading
from collections.abc import Iterable
from importlib.metadata import PackageNotFoundError, version
from types import TracebackType
from typing import Any, BinaryIO

from mcap.writer import CompressionType, Writer

from racecar_sim.core.errors import RecordingError
from racecar_sim.msgs import msgtype_of, schema_text, serialize
from racecar_sim.recording.chunk_compression import compress_chunks
from racecar_sim.recording.chunk_index_spill import spill_chunk_indexes
from racecar_sim.recording.chunk_messages import (
    MESSAGE_FIXED,
    MESSAGE_OPCODE,
    MESSAGE_RECORD,
    ChunkIndex,
    ChunkMessages,
)

# these lived here before they had modules of their own: still importable from here
from racecar_sim.recording.deferred_interrupt import DeferredInterrupt as DeferredInterrupt
from racecar_sim.recording.recording_file import RecordingFileError as RecordingFileError
from racecar_sim.recording.recording_file import RecordingInUseError as RecordingInUseError
from racecar_sim.recording.recording_file import open_recording_file as open_recording_file

_COMPRESSION = {
    "zstd": CompressionType.ZSTD,
    "lz4": CompressionType.LZ4,
    "none": CompressionType.NONE,
}
_UINT64_MAX = 2**64 - 1
CHUNK_DURATION_NS = 1_000_000_000
"""A chunk is closed before it would span this much log time (sim time): what a crash can lose."""


class RecordingWriteError(RecordingError, OSError):
    """The recording's file stopped taking bytes (disk full, a file size limit, an I/O error): one line naming the
    file, the sim time it failed at and what it keeps (every chunk written before, without the index:
    `racecar-sim recover` makes it readable). Also the OSError that stopped it (its errno, strerror, filename)."""

    message = ""

    def __str__(self) -> str:
        return self.message or super().__str__()


def _qos_profiles_v8(durability: int, depth: int) -> str:
    """``offered_qos_profiles`` YAML in rosbag2's metadata version 8 form, as rosbags writes it.

    Version 8 writes the policies as rmw enum integers (history KEEP_LAST = 1,
    reliability RELIABLE = 1, durability TRANSIENT_LOCAL = 1 / VOLATILE = 2,
    liveliness AUTOMATIC = 1); version 9 (Jazzy) writes lower-case names instead.
    Humble reads only the integers; Jazzy and later read them when the file says it is
    version 8, which the ``rosbag2`` metadata record written by the recorder does.
    """
    zero = "{nsec: 0, sec: 0}"
    return (
        "- avoid_ros_namespace_conventions: false\n"
        f"  deadline: {zero}\n"
        f"  depth: {depth}\n"
        f"  durability: {durability}\n"
        "  history: 1\n"
        f"  lifespan: {zero}\n"
        "  liveliness: 1\n"
        f"  liveliness_lease_duration: {zero}\n"
        "  reliability: 1"
    )


LATCHED_QOS = _qos_profiles_v8(durability=1, depth=1)
"""Reliable, transient-local (latched), keep-last 1: what a static tf broadcaster offers."""
VOLATILE_QOS = _qos_profiles_v8(durability=2, depth=10)
"""Reliable, volatile, keep-last 10: rclcpp's default publisher QoS."""


class McapRecorder:
    """Writes messages to an MCAP file that ``ros2 bag``, rosbags, Foxglove and PlotJuggler read.

    Each message is serialized to ROS 2 CDR by :func:`racecar_sim.msgs.serialize`. The
    schema (``ros2msg``, the concatenated ``.msg`` text) and the channel (encoding
    ``cdr``) of a topic are registered the first time the topic is written. The header
    profile is ``ros2`` and chunks are compressed (zstd at level 1 by default:
    recording/chunk_compression.py). Times are the caller's integer nanoseconds,
    normally sim time, never the wall clock.

    Every channel carries ``offered_qos_profiles`` metadata. Topics in
    ``latched_topics`` (default ``/tf_static``) declare TRANSIENT_LOCAL durability, so
    ``ros2 bag play`` republishes them latched; the others declare rclcpp's default
    reliable, volatile QoS.

    Interruption: use it as a context manager. An exception or KeyboardInterrupt inside
    the ``with`` block still closes the file with its summary and footer, and SIGINT
    arriving during ``write()`` or ``close()`` is delivered once the writer is consistent
    again.

    Crashes: a chunk is closed when it reaches ``chunk_size`` bytes and also before it
    would span :data:`CHUNK_DURATION_NS` (1 s) of log time, and each closed chunk is
    flushed to the OS at once. A SIGKILL, the OOM killer or a crash of the interpreter
    therefore loses only the chunk in progress: less than one second of sim time. Such
    a file has no summary or footer: readers that seek to the footer (rosbags,
    ``ros2 bag``) reject it, while a streaming reader gets every closed chunk and then
    fails at the cut. :func:`racecar_sim.recording.recover_mcap` (``racecar-sim
    recover``) or ``mcap recover`` rewrite it as a complete file. Chunk boundaries
    depend only on the messages and their log times, so same-seed runs still give
    byte-identical files.

    Args:
        path: Output file; it is created or truncated.
        compression: ``"zstd"``, ``"lz4"`` or ``"none"``.
        chunk_size: Uncompressed bytes per chunk before it is compressed and written.
        latched_topics: Topics recorded with TRANSIENT_LOCAL durability.
        stream: The file already opened for writing (by :func:`open_recording_file`,
            e.g. in another process); ``path`` then only names it. Closed by close().

    Raises:
        RecordingFileError: The file cannot be created (a directory, a missing or
            read-only folder): a one-line :class:`RecordingError` naming the path that
            is also the ``OSError`` subclass ``open()`` raised.
        ValueError: Unknown compression.
    """

    def __init__(
        self,
        path: str | os.PathLike[str],
        *,
        compression: str = "zstd",
        chunk_size: int = 1024 * 1024,
        latched_topics: Iterable[str] = ("/tf_static",),
        stream: BinaryIO | None = None,
    ) -> None:
        if compression not in _COMPRESSION:
            choices = ", ".join(_COMPRESSION)
            raise ValueError(f"compression must be one of {choices}; got {compression!r}")
        self.path = os.fspath(path)
        self.latched_topics = frozenset(latched_topics)
        self._lock = threading.Lock()
        self._closed = False
        self._schemas: dict[str, int] = {}
        self._channels: dict[str, tuple[int, str]] = {}
        self._counts: dict[str, int] = {}
        self._flushed = 0
        self._chunk_times: tuple[int, int] | None = None  # log-time span of the chunk in progress
        self._kept_ns: int | None = None  # the last log time of the chunks handed to the OS
        self._failed: RecordingWriteError | None = None
        self._stream = open_recording_file(self.path) if stream is None else stream
        self._interrupt = DeferredInterrupt()
        self._interrupt.hold()
        try:
            self._writer = Writer(self._stream, chunk_size=chunk_size, compression=_COMPRESSION[compression])
            spill_chunk_indexes(self._writer, self.path, self._stream)  # memory flat in a long recording
            compress_chunks(self._writer)  # zstd at level 1, not 3: 40 % of the CPU for 2 % more bytes
            self._chunk_messages = ChunkMessages.of(self._writer)  # add_message's bytes, at a third of its cost
            self._writer.start(profile="ros2", library=_library())
            # With a 'rosbag2' record lacking 'serialized_metadata', rosbag2 (Jazzy and
            # later) decodes offered_qos_profiles as metadata version 8, our integer form.
            self._writer.add_metadata("rosbag2", {"ROS_DISTRO": "racecar_sim"})
            self._stream.flush()  # the header is on disk from the start
            self._flushed = self._stream.tell()
        except OSError as exc:  # the file takes no bytes (a full disk): one line, the file left empty
            raise self._give_up(exc, "at its start") from None
        except BaseException:
            self._stream.close()
            self._interrupt.uninstall()
            raise
        finally:
            self._interrupt.release()

    @property
    def message_count(self) -> dict[str, int]:
        """Messages written so far, per topic."""
        with self._lock:
            return dict(self._counts)

    @property
    def closed(self) -> bool:
        """Whether :meth:`close` has run."""
        return self._closed

    def write(self, topic: str, msg: Any, log_time_ns: int, publish_time_ns: int | None = None) -> None:
        """Serialize ``msg`` and append it to ``topic``.

        Args:
            topic: Topic name, e.g. ``/scan``.
            msg: A message instance from :mod:`racecar_sim.msgs`.
            log_time_ns: Record time in integer nanoseconds (sim time).
            publish_time_ns: Publish time; defaults to ``log_time_ns``.

        Raises:
            ValueError: The recorder is closed, a time is not in [0, 2**64), or the topic
                was already recorded with another message type.
            TypeError: ``msg`` is not a message or has a badly typed field.
        """
        self.write_serialized(topic, msgtype_of(msg), serialize(msg), log_time_ns, publish_time_ns)

    def write_serialized(
        self, topic: str, msgtype: str, data: bytes, log_time_ns: int, publish_time_ns: int | None = None
    ) -> None:
        """:meth:`write` for a message already serialized to CDR (``msgtype``: ``pkg/msg/Name``).

        A caller that writes on another thread serializes first, so a message changed after
        it was published is recorded as it was.
        """
        log_time = _timestamp(log_time_ns, "log_time_ns")
        publish_time = log_time if publish_time_ns is None else _timestamp(publish_time_ns, "publish_time_ns")
        with self._lock:
            self._check_writable()
            self._interrupt.hold()
            try:
                self._append(topic, msgtype, data, log_time, publish_time)
            except OSError as exc:
                raise self._give_up(exc, f"at sim time {log_time / 1e9:.3f} s") from None
            finally:
                self._interrupt.release()

    def write_many(self, messages: Iterable[tuple[str, str, bytes, int]]) -> None:
        """:meth:`write_serialized` of each ``(topic, msgtype, data, log_time_ns)`` in turn (publish time = log time),
        under one hold of the lock and of SIGINT: what a writer process does with a hand-over's messages."""
        with self._lock:
            self._check_writable()
            self._interrupt.hold()
            log_time = 0
            try:
                if self._chunk_messages is not None:
                    log_time = self._append_many(messages, self._chunk_messages)
                else:
                    for topic, msgtype, data, log_time_ns in messages:
                        log_time = _timestamp(log_time_ns, "log_time_ns")
                        self._append(topic, msgtype, data, log_time, log_time)
            except OSError as exc:
                raise self._give_up(exc, f"at sim time {log_time / 1e9:.3f} s") from None
            finally:
                self._interrupt.release()

    def _append_many(self, messages: Iterable[tuple[str, str, bytes, int]], fast: ChunkMessages) -> int:
        """_append() of each message (publish time = log time), the usual one inline: a topic already recorded with
        that type, in the chunk in progress, less than CHUNK_DURATION_NS after its first message (the updates
        ChunkMessages.add makes, with the writer's state read once). The others (a new topic, a chunk to close by time)
        go through _append. Returns the last log time.

        Inline, the records' bytes are gathered and written to the chunk together, and the counts and the latest log
        time are added to the writer's state then (_settle): before a message goes through _append, before a full
        chunk is closed, and at the end. The chunk's offsets are counted here meanwhile (the records' lengths)."""
        statistics, builder, chunk_size = fast.statistics, fast.builder, fast.chunk_size
        indices, channel_counts = builder.message_indices, statistics.channel_message_counts
        channels, counts, pack, fixed = self._channels, self._counts, MESSAGE_RECORD.pack, MESSAGE_FIXED
        record = MESSAGE_RECORD.size
        buffer = builder.record_writer._buffer
        offset = buffer.tell()  # where the next record goes in the chunk
        parts: list[bytes] = []  # records not yet written to the chunk
        added = 0  # messages inline not yet counted in the writer's state
        span = self._chunk_times
        log_time = latest = 0
        for topic, msgtype, data, log_time in messages:
            if type(log_time) is not int or not 0 <= log_time <= _UINT64_MAX:
                log_time = _timestamp(log_time, "log_time_ns")
            channel = channels.get(topic)
            if (
                span is None
                or channel is None
                or channel[1] != msgtype
                or log_time < span[0]
                or log_time - span[0] >= CHUNK_DURATION_NS
            ):
                if added:
                    span = self._settle(span, parts, added, latest)
                    parts, added, latest = [], 0, 0
                self._chunk_times = span
                self._append(topic, msgtype, data, log_time, log_time)
                span = self._chunk_times
                buffer = builder.record_writer._buffer
                offset = buffer.tell()
                continue
            # the chunk holds a message already, none before log_time: no start time moves
            channel_id = channel[0]
            count = counts[topic] + 1
            counts[topic] = count
            channel_counts[channel_id] += 1
            if log_time > latest:
                latest = log_time
            index = indices.get(channel_id)
            if index is None:
                index = indices[channel_id] = ChunkIndex(channel_id=channel_id, records=[])
            index.records.append((log_time, offset))
            size = len(data)
            parts.append(pack(MESSAGE_OPCODE, fixed + size, channel_id, count & 0xFFFFFFFF, log_time, log_time))
            parts.append(data)
            offset += record + size
            added += 1
            if offset > chunk_size:  # full: closed as add_message closes it
                span = self._settle(span, parts, added, latest)
                # the latest is each settle's own: the next chunk's end time is its messages' latest, not this one's
                parts, added, latest = [], 0, 0
                self._chunk_times = span
                fast.finalize()
                self._chunk_written()
                span = self._chunk_times
                buffer = builder.record_writer._buffer
                offset = buffer.tell()
        if added:
            span = self._settle(span, parts, added, latest)
        self._chunk_times = span
        return log_time

    def _settle(
        self, span: tuple[int, int] | None, parts: list[bytes], added: int, latest: int
    ) -> tuple[int, int] | None:
        """_append_many's records written to the chunk, and its `added` messages (the latest at `latest`) counted in
        the writer's state as ChunkMessages.add counts them; the chunk's log-time span then."""
        fast = self._chunk_messages
        assert fast is not None and span is not None
        statistics, builder = fast.statistics, fast.builder
        builder.record_writer._buffer.writelines(parts)
        statistics.message_count += added
        builder.num_messages += added
        if latest > statistics.message_end_time:
            statistics.message_end_time = latest
        if latest > builder.message_end_time:
            builder.message_end_time = latest
        return (span[0], latest) if latest > span[1] else span

    def _check_writable(self) -> None:
        """Raise what a write to a failed or closed recorder raises (the lock held)."""
        if self._failed is not None:
            raise self._failed
        if self._closed:
            raise ValueError(f"write to a closed recorder ({self.path})")

    def _append(self, topic: str, msgtype: str, data: bytes, log_time: int, publish: int) -> None:
        if self._chunk_times is not None:
            first, last = self._chunk_times
            if max(last, log_time) - min(first, log_time) >= CHUNK_DURATION_NS:
                # Writer.flush() is mcap's public way to end the chunk in progress: it
                # compresses and writes it with its message indexes, then flushes the file.
                self._writer.flush()
                self._chunk_written()
        channel = self._channels.get(topic)
        if channel is None or channel[1] != msgtype:
            channel = self._channel(topic, msgtype)
            self._chunk_written()  # registering may close a full chunk too
        count = self._counts[topic] + 1
        fast = self._chunk_messages
        if fast is None:
            self._writer.add_message(channel[0], log_time, data, publish, count & 0xFFFFFFFF)
            closed = True  # maybe: _chunk_written() looks
        else:
            closed = fast.add(channel[0], log_time, data, publish, count & 0xFFFFFFFF)
        self._counts[topic] = count
        first, last = self._chunk_times or (log_time, log_time)
        self._chunk_times = (min(first, log_time), max(last, log_time))
        if closed:
            self._chunk_written()  # a chunk closed by size holds this message too

    def _chunk_written(self) -> bool:
        """Whether the writer wrote a chunk since the last call; if so, hand it to the OS.

        Bytes reach the file only when a chunk is closed (by size inside ``add_message``
        or ``register_*``, or by time through ``Writer.flush()``), so a moved position
        means the chunk in progress was written: flush it so a SIGKILL cannot lose it.
        """
        if self._stream.tell() == self._flushed:
            return False
        self._stream.flush()
        self._flushed = self._stream.tell()
        if self._chunk_times is not None:
            self._kept_ns = max(self._kept_ns or 0, self._chunk_times[1])
        self._chunk_times = None
        return True

    def _give_up(self, exc: OSError, when: str) -> RecordingWriteError:
        """The file stopped taking bytes: cut it back to its last complete chunk (what a crash would leave, which
        `racecar-sim recover` reads), let go of it, and the one-line error saying what it keeps."""
        self._closed = True
        fd = self._stream.fileno()
        with contextlib.suppress(OSError):
            os.ftruncate(fd, self._flushed)
        with contextlib.suppress(OSError):  # the bytes still buffered go nowhere: the file stays cut there
            null = os.open(os.devnull, os.O_WRONLY)
            os.dup2(null, fd)
            os.close(null)
        with contextlib.suppress(OSError, ValueError):
            self._stream.close()
        self._interrupt.uninstall()
        if self._kept_ns is None:
            kept = "it keeps no message"
        else:
            kept = (
                f"it keeps the messages up to sim time {self._kept_ns / 1e9:.3f} s, without its index: "
                f"`racecar-sim recover {self.path}` makes it readable"
            )
        self._failed = RecordingWriteError(exc.errno, exc.strerror or str(exc), self.path)
        self._failed.message = (
            f"{self.path}: the recording stopped {when}: cannot write the file ({exc.strerror or exc}); {kept}"
        )
        return self._failed

    def _channel(self, topic: str, msgtype: str) -> tuple[int, str]:
        if topic in self._channels:
            recorded = self._channels[topic][1]
            raise ValueError(f"topic {topic!r} is recorded as {recorded}; cannot also record {msgtype} on it")
        schema_id = self._schemas.get(msgtype)
        if schema_id is None:
            schema = schema_text(msgtype).encode()
            schema_id = self._writer.register_schema(msgtype, "ros2msg", schema)
            self._schemas[msgtype] = schema_id
        qos = LATCHED_QOS if topic in self.latched_topics else VOLATILE_QOS
        channel_id = self._writer.register_channel(topic, "cdr", schema_id, {"offered_qos_profiles": qos})
        self._channels[topic] = (channel_id, msgtype)
        self._counts[topic] = 0
        return self._channels[topic]

    def close(self) -> None:
        """Write the last chunk, the summary and the footer, and close the file. Idempotent."""
        with self._lock:
            if self._closed:
                return
            self._closed = True
            self._interrupt.hold()
            try:
                self._writer.finish()
                self._stream.close()
            except OSError as exc:
                raise self._give_up(exc, "while finishing it") from None
            finally:
                if not self._stream.closed:
                    self._stream.close()
                self._interrupt.uninstall()
                self._interrupt.release()

    def __enter__(self) -> McapRecorder:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        traceback: TracebackType | None,
    ) -> None:
        self.close()

    def __repr__(self) -> str:
        state = "closed" if self._closed else f"{sum(self._counts.values())} messages"
        return f"McapRecorder({self.path!r}, {state})"


def _library() -> str:
    try:
        return f"racecar-sim {version('racecar-sim')}"
    except PackageNotFoundError:
        return "racecar-sim"


def _timestamp(value: int, name: str) -> int:
    try:
        ns = int(value.__index__())
    except (AttributeError, TypeError):
        raise TypeError(f"{name} must be an integer number of nanoseconds, got {value!r}") from None
    if not 0 <= ns <= _UINT64_MAX:
        raise ValueError(f"{name} must be in [0, 2**64), got {ns}")
    return ns
