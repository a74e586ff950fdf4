"""What `racecar-sim run` records: every bus topic to an MCAP file, written on a writer thread, camera images as
JPEG CompressedImage on `<image topic>/compressed` (or raw Image on request)."""

from __future__ import annotations

import os
from collections.abc import Callable, Iterable
from types import TracebackType
from typing import Any

from racecar_sim.bus import Bus
from racecar_sim.msgs import Image, msgtype_of, serialize
from racecar_sim.recording.images import JPEG_QUALITY, compress_image, compressed_topic
from racecar_sim.recording.mcap_recorder import McapRecorder
from racecar_sim.recording.writer_thread import WriterThread

COMPRESSED_MSGTYPE = "sensor_msgs/msg/CompressedImage"
BATCH = 32  # messages handed to the writer thread at once (a few ms of sim time)


class RunRecording:
    """Records every message on `bus` to the MCAP file `path`, log time `clock()` (sim time, integer ns).

    Messages are serialized where they are published (one changed later is recorded as it was) and written on a
    WriterThread in publication order, so the file is byte for byte the one writing in place would give: same
    seed, same bytes. Images on `image_topics` are recorded as ROS users record camera images, JPEG
    `sensor_msgs/CompressedImage` on `<topic>/compressed`, encoded on the writer thread; `raw_images` keeps them
    as the raw `sensor_msgs/Image` on the topic itself. Latched topics' last messages are written first.

    close() (or leaving the `with` block, whatever the reason) writes everything published before it and
    finishes the file; an error met while writing is raised by a later publish or by close(), after the file
    is finished. `recorder`: the McapRecorder underneath.
    """

    def __init__(self, bus: Bus, clock: Callable[[], int], path: str | os.PathLike[str], *,
                 image_topics: Iterable[str] = (), raw_images: bool = False, jpeg_quality: int = JPEG_QUALITY,
                 compression: str = "zstd") -> None:
        self.recorder = McapRecorder(path, compression=compression)
        self.clock = clock
        self.jpeg_quality = jpeg_quality
        self.compressed = {} if raw_images else {topic: compressed_topic(topic) for topic in image_topics}
        self.writer = WriterThread(f"record {self.recorder.path}")
        self._closed = False
        self._batch: list[tuple[str, str | None, Any, int]] = []
        try:
            for topic, msg in bus.latched_messages().items():
                self._record(topic, msg)
        except BaseException:
            self.close()
            raise
        self._untap = bus.tap(self._record)

    def _record(self, topic: str, msg: object) -> None:
        # the writer thread gets batches: a queue hand-over per message would cost more than most messages' writing
        if topic in self.compressed and isinstance(msg, Image):
            self._batch.append((self.compressed[topic], None, msg, self.clock()))
        else:
            self._batch.append((topic, msgtype_of(msg), serialize(msg), self.clock()))
        if len(self._batch) >= BATCH:
            self._submit()

    def _submit(self) -> None:
        batch, self._batch = self._batch, []
        if batch:
            self.writer.submit(lambda: self._write(batch))

    def _write(self, batch: list[tuple[str, str | None, Any, int]]) -> None:
        for topic, msgtype, data, now in batch:
            if msgtype is None:  # an Image to record as JPEG
                msgtype, data = COMPRESSED_MSGTYPE, serialize(compress_image(data, self.jpeg_quality))
            self.recorder.write_serialized(topic, msgtype, data, now)

    @property
    def path(self) -> str:
        """The MCAP file's path."""
        return self.recorder.path

    def close(self) -> None:
        """Stop recording, write what was published so far and finish the file (summary, footer). Idempotent."""
        if self._closed:
            return
        self._closed = True
        untap = getattr(self, "_untap", None)
        try:
            if untap is not None:
                untap()
            self._submit()
            self.writer.close()
        finally:
            self.recorder.close()

    def __enter__(self) -> RunRecording:
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.close()
