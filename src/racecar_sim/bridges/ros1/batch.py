"""Messages to the ROS side in batches: one pipe write for many messages instead of one each.

Every write to the pipe wakes the ROS side's process; at the sim's message rates (a few hundred per sim second,
tens of thousands per wall second when the sim runs ahead of the wall clock) the wake-ups, not the bytes, were what
held the sim back. So DATA frames wait here and go out together as one BATCH frame whose payload is those frames
back to back (each its uint32 length, its kind byte DATA, the topic's uint32 id and the ROS 1 bytes): at the first
drain FLUSH_WALL after the last batch, when FLUSH_BYTES wait, when one topic has `per_topic` messages waiting (the
ROS side hands a batch to rospy at once, and a rospy publisher queue holds queue_size messages per reader: a batch
must not overflow it), and whenever the owner calls flush() (spin_once: after each slice of a run loop, so nothing
waits through a real-time pause).

A topic marked `latest_only` (/clock) keeps one message in a batch: a newer one replaces the one waiting and goes
at the newer one's place. A batch spans a few milliseconds of wall time; ROS nodes keep only the newest /clock
(rospy and roscpp subscribe to it with a queue of one), so the ones in between would be read and dropped. A run
paced to the wall clock sends what each slice published (10 ms of sim time: one /clock) before it waits for the wall
clock, so this happens only when the sim runs ahead (--fast).
"""

from __future__ import annotations

import struct
import time
from collections.abc import Callable

BATCH = 2  # frame kind: DATA frames back to back (CONTROL 0 and DATA 1 are link.py's)
_DATA = 1
_SUB = struct.Struct("<IBI")  # a DATA frame's head inside a batch: length of what follows, kind, topic id
FLUSH_WALL = 0.005  # s of wall time a message may wait for others to go with it
FLUSH_BYTES = 1 << 20  # bytes that go out at once, whatever the time
_JOIN = 1 << 16  # parts smaller than this are joined into one write


class FrameBatch:
    """DATA frames waiting for the pipe. `send(kind, *parts)` is the link's (one frame, its parts back to back)."""

    def __init__(self, send: Callable[..., None], per_topic: int = 5) -> None:
        self._send = send
        self.per_topic = per_topic
        self._parts: list[bytes] = []
        self._counts: dict[int, int] = {}  # topic id -> messages waiting
        self.latest_only: set[int] = set()  # topic ids whose newest message replaces the one waiting
        self._waiting: dict[int, int] = {}  # latest_only topic id -> index of its head in _parts
        self.replaced = 0  # messages replaced by a newer one before they went out
        self._bytes = 0
        self._last = time.perf_counter()
        self.batches = 0  # batches sent

    def add(self, topic_id: int, data: bytes) -> None:
        """Queue one message of topic `topic_id` (its ROS 1 bytes)."""
        parts = self._parts
        if topic_id in self.latest_only:
            index = self._waiting.get(topic_id)
            if index is not None:  # the older one goes (its frame emptied, its place kept)
                self._bytes -= len(parts[index]) + len(parts[index + 1])
                parts[index] = parts[index + 1] = b""
                self.replaced += 1
            self._waiting[topic_id] = len(parts)
            count = 1
        else:
            count = self._counts[topic_id] = self._counts.get(topic_id, 0) + 1
        parts.append(_SUB.pack(len(data) + 5, _DATA, topic_id))
        parts.append(data)
        self._bytes += len(data) + _SUB.size
        if count >= self.per_topic or self._bytes >= FLUSH_BYTES:
            self.flush()

    def flush_due(self) -> None:
        """Send what waits if FLUSH_WALL has passed since the last batch."""
        if self._parts and time.perf_counter() - self._last >= FLUSH_WALL:
            self.flush()

    def flush(self) -> None:
        """Send what waits now."""
        if not self._parts:
            return
        parts, self._parts, self._bytes = self._parts, [], 0
        self._counts.clear()
        self._waiting.clear()
        self._send(BATCH, *_coalesce(parts))
        self.batches += 1
        self._last = time.perf_counter()


def _coalesce(parts: list[bytes]) -> list[bytes]:
    """Runs of small parts joined (one write each), large ones (camera images) kept as they are (no copy)."""
    out: list[bytes] = []
    run: list[bytes] = []
    for part in parts:
        if len(part) < _JOIN:
            run.append(part)
            continue
        if run:
            out.append(b"".join(run))
            run = []
        out.append(part)
    if run:
        out.append(b"".join(run))
    return out


def split(payload: bytes) -> list[tuple[int, bytes]]:
    """(topic id, message bytes) of each DATA frame in a BATCH payload (what the ROS side does, for tests)."""
    frames, pos = [], 0
    while pos < len(payload):
        size, _, topic_id = _SUB.unpack_from(payload, pos)
        frames.append((topic_id, payload[pos + _SUB.size : pos + 4 + size]))
        pos += 4 + size
    return frames
