"""What `racecar-sim run` records: every bus topic to an MCAP file, written by a writer process (or thread), camera
images as JPEG CompressedImage on `<image topic>/compressed` (or raw Image on request)."""

from __future__ import annotations

import logging
import os
from collections.abc import Callable, Iterable
from types import TracebackType
from typing import TYPE_CHECKING, Any

from racecar_sim.bus import Bus, RowPacker
from racecar_sim.msgs import Image, msgtype_of, serialize
from racecar_sim.recording.images import JPEG_QUALITY, compress_image, compressed_topic
from racecar_sim.recording.recording_file import open_recording_file
from racecar_sim.recording.writer_process import JPEG, OPEN_MCAP, WriterProcess
from racecar_sim.recording.writer_thread import WriterThread

if TYPE_CHECKING:
    from racecar_sim.recording.mcap_recorder import McapRecorder

log = logging.getLogger("racecar_sim")

COMPRESSED_MSGTYPE = "sensor_msgs/msg/CompressedImage"
THREAD_BATCH = 32  # messages handed to the fallback writer thread at once (a few ms of sim time, images included)


class _MsgTypes(dict[type, str]):
    """Message class -> its pkg/msg/Name (msgtype_of), found the first time a class is asked for."""

    def __missing__(self, cls: type) -> str:
        msgtype = self[cls] = msgtype_of(cls)
        return msgtype


class RunRecording:
    """Records every message on `bus` to the MCAP file `path`, log time `clock()` (sim time, integer ns).

    Messages are serialized where they are published (one changed later is recorded as it was) and written in
    publication order by a WriterProcess (`process=False`, or where no process can start: a WriterThread), so the
    file is byte for byte the one writing in place would give: same seed, same bytes. Images on `image_topics` are
    recorded as ROS users record camera images, JPEG `sensor_msgs/CompressedImage` on `<topic>/compressed`,
    encoded by the writer; `raw_images` keeps them as the raw `sensor_msgs/Image` on the topic itself. Latched
    topics' last messages are written first. A path that cannot be written raises RecordingFileError here; one that
    another recording is writing, or (without `overwrite`) one that exists, RecordingInUseError
    (recording_file.open_recording_file: the file is held exclusively until it is finished).

    close() (or leaving the `with` block, whatever the reason) writes everything published before it and
    finishes the file; an error met while writing is raised by a later publish or by close(), after the file
    is finished. `process`: the WriterProcess (None on a thread; a video may share it, see ProcessVideo);
    `recorder`: the McapRecorder underneath when writing on a thread.
    """

    def __init__(
        self,
        bus: Bus,
        clock: Callable[[], int],
        path: str | os.PathLike[str],
        *,
        image_topics: Iterable[str] = (),
        raw_images: bool = False,
        jpeg_quality: int = JPEG_QUALITY,
        compression: str = "zstd",
        process: bool = True,
        overwrite: bool = True,
    ) -> None:
        self._path = os.fspath(path)
        stream = open_recording_file(self._path, overwrite)  # a bad path is the caller's error now, not the writer's
        self.clock = clock
        self.jpeg_quality = jpeg_quality
        self.compressed = {} if raw_images else {topic: compressed_topic(topic) for topic in image_topics}
        self.process: WriterProcess | None = None
        self.recorder: McapRecorder | None = None
        self.writer: WriterThread | None = None
        self._closed = False
        self._batch: list[tuple[str, str | None, Any, int]] = []
        if process:
            fd = stream.fileno()  # the child's copy is named by this number
            try:
                self.process = WriterProcess.open(f"record {self._path}", pass_fds=[fd])
            except OSError as exc:
                log.warning("no writer process (%s): recording on a writer thread", exc)
            else:
                stream.close()
                self.process.send((OPEN_MCAP, fd, self._path, compression))
        if self.process is None:
            from racecar_sim.recording.mcap_recorder import McapRecorder  # the writer in this process: loaded only now

            self.recorder = McapRecorder(self._path, compression=compression, stream=stream)
            self.writer = WriterThread(f"record {self._path}")
        self._msgtypes = _MsgTypes()  # message class -> pkg/msg/Name, looked up once per class
        try:
            for topic, msg in bus.latched_messages().items():
                self._record(topic, msg)
        except BaseException:
            self.close()
            raise
        self._untap = bus.tap(self._record, cdr=self._record_cdr, cdr_rows=self._record_cdr_rows)

    def _record(self, topic: str, msg: object) -> None:
        if self.process is not None:
            if topic in self.compressed and isinstance(msg, Image):
                self.process.send(
                    (
                        JPEG,
                        self.compressed[topic],
                        COMPRESSED_MSGTYPE,
                        self.process.image(msg),
                        self.clock(),
                        self.jpeg_quality,
                    )
                )
            else:
                self.process.message(topic, self._msgtypes[type(msg)], serialize(msg), self.clock())
            return
        # the writer thread gets batches: a queue hand-over per message would cost more than most messages' writing
        if topic in self.compressed and isinstance(msg, Image):
            self._batch.append((self.compressed[topic], None, msg, self.clock()))
        else:
            self._batch.append((topic, self._msgtypes[type(msg)], serialize(msg), self.clock()))
        if len(self._batch) >= THREAD_BATCH:
            self._submit()

    def _record_cdr(self, topic: str, cls: type, data: bytes) -> None:
        """A message handed over as its CDR bytes (Bus.publish_cdr: the recording is its only taker)."""
        msgtype = self._msgtypes[cls]
        if self.process is not None:
            self.process.message(topic, msgtype, data, self.clock())
            return
        self._batch.append((topic, msgtype, data, self.clock()))
        if len(self._batch) >= THREAD_BATCH:
            self._submit()

    def _record_cdr_rows(
        self, cls: type, packer: RowPacker, topics: tuple[str, ...], rows: list[tuple[Any, ...]]
    ) -> None:
        """Messages of one class published at one moment, as their numbers and what packs them (Bus.publish_cdr_rows):
        one look-up of their type and of the time, one hand-over; a writer process packs them, a thread's batch holds
        them packed."""
        msgtype = self._msgtypes[cls]
        now = self.clock()
        if self.process is not None:
            self.process.rows(msgtype, packer, topics, rows, now)
            return
        self._batch.extend([(topic, msgtype, data, now) for topic, data in zip(topics, packer.pack_many(rows))])
        if len(self._batch) >= THREAD_BATCH:
            self._submit()

    def _submit(self) -> None:
        batch, self._batch = self._batch, []
        if batch and self.writer is not None:
            self.writer.submit(lambda: self._write(batch))

    def _write(self, batch: list[tuple[str, str | None, Any, int]]) -> None:
        assert self.recorder is not None
        for topic, msgtype, data, now in batch:
            if msgtype is None:  # an Image to record as JPEG
                msgtype, data = COMPRESSED_MSGTYPE, serialize(compress_image(data, self.jpeg_quality))
            self.recorder.write_serialized(topic, msgtype, data, now)

    @property
    def path(self) -> str:
        """The MCAP file's path."""
        return self._path

    @property
    def message_count(self) -> dict[str, int]:
        """Messages written per topic: so far on a writer thread; from a writer process, once closed."""
        if self.recorder is not None:
            return self.recorder.message_count
        return dict(self.process.results.get("counts", {})) if self.process is not None else {}

    def close(self) -> None:
        """Stop recording, write what was published so far and finish the file (summary, footer). Idempotent."""
        if self._closed:
            return
        self._closed = True
        untap = getattr(self, "_untap", None)
        if untap is not None:
            untap()
        if self.process is not None:
            self.process.close()
            return
        try:
            self._submit()
            if self.writer is not None:
                self.writer.close()
        finally:
            if self.recorder is not None:
                self.recorder.close()

    def __enter__(self) -> RunRecording:
        return self

    def __exit__(
        self, exc_type: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> None:
        self.close()
