"""The pipe between a bridge and its ROS side: length-prefixed frames over the side process's stdin and stdout.

A frame is a little-endian uint32 length of what follows, one byte of kind, the payload. CONTROL payloads are
pickled dicts with an "op" (protocol 4); DATA payloads a uint32 id (a topic's, given by the sim) and the message bytes;
a BATCH payload is DATA frames back to back. Messages going to the side wait in a batch (SideLink.add) until the
owner flushes it: one pipe write, and one wake-up of the side, for many messages. At the sim's rates (thousands of
messages per wall second when it runs ahead of the wall clock) the wake-ups, not the bytes, are what costs.

SideLink is the sim's end (it starts the process; a reader thread hands frames on). PipeEnd is the side's end. This
module uses the standard library only: a ROS side, run under the ROS interpreter without racecar_sim installed, loads
it from its path.
"""

from __future__ import annotations  # a ROS interpreter may be older than the sim's

import fcntl
import os
import pickle
import struct
import subprocess
import threading
from collections.abc import Callable, Mapping, Sequence
from typing import IO, Any

CONTROL, DATA, BATCH = 0, 1, 2
HEAD = struct.Struct("<IB")
ID = struct.Struct("<I")
_DATA_HEAD = struct.Struct("<IBI")  # a DATA frame's head with its id: length of what follows, kind, id
BATCH_BYTES = 1 << 20  # a batch this large goes out at once
PIPE_BYTES = 1 << 20  # the pipe's buffer towards the side, where the system allows it


class SideLink:
    """The ROS side process and its pipe. `on_frame(kind, payload)` runs on the reader thread."""

    def __init__(
        self,
        command: Sequence[str],
        env: Mapping[str, str],
        on_frame: Callable[[int, bytes], None],
        name: str = "bridge-reader",
    ) -> None:
        self.process = subprocess.Popen(
            list(command), stdin=subprocess.PIPE, stdout=subprocess.PIPE, env=dict(env), start_new_session=True
        )
        assert self.process.stdin is not None and self.process.stdout is not None  # both are PIPE
        self._stdin, self._stdout = self.process.stdin, self.process.stdout
        _widen(self._stdin.fileno())
        self._on_frame = on_frame
        self._lock = threading.Lock()
        self._batch: list[bytes | memoryview] = []
        self._batch_bytes = 0
        self._latest: dict[int, int] = {}  # topic id -> where its message is in the batch (latest_only topics)
        self.batches = 0  # batches sent
        self.closed = threading.Event()
        self._reader = threading.Thread(target=self._read_loop, name=name, daemon=True)
        self._reader.start()

    def send(self, kind: int, *parts: bytes | memoryview) -> None:
        """One frame; `parts` are written back to back (no copy of a large message)."""
        size = 1 + sum(len(p) if not isinstance(p, memoryview) else p.nbytes for p in parts)
        stdin = self._stdin
        with self._lock:
            try:
                stdin.write(HEAD.pack(size, kind))
                for part in parts:
                    stdin.write(part)
                stdin.flush()
            except (BrokenPipeError, ValueError):
                self.closed.set()

    def send_control(self, **fields: Any) -> None:
        """A CONTROL frame of `fields` (an "op" and its arguments), after the messages waiting in the batch."""
        self.flush()
        self.send(CONTROL, pickle.dumps(fields, protocol=4))

    def add(self, topic_id: int, data: bytes | memoryview, latest_only: bool = False) -> bool:
        """A DATA frame of `topic_id` into the batch (sent by flush(); at once past BATCH_BYTES). `latest_only`:
        it replaces the topic's message waiting in the batch, if any (a topic whose readers keep only the last);
        False then."""
        size = len(data) if not isinstance(data, memoryview) else data.nbytes
        head = _DATA_HEAD.pack(size + 5, DATA, topic_id)
        if latest_only:
            slot = self._latest.get(topic_id)
            if slot is not None:
                self._batch[slot], self._batch[slot + 1] = head, data
                return False
            self._latest[topic_id] = len(self._batch)
        self._batch.append(head)
        self._batch.append(data)
        self._batch_bytes += size + _DATA_HEAD.size
        if self._batch_bytes >= BATCH_BYTES:
            self.flush()
        return True

    def flush(self) -> None:
        """Send the batch as one BATCH frame."""
        if not self._batch:
            return
        parts, self._batch, self._batch_bytes = self._batch, [], 0
        self._latest.clear()
        self.send(BATCH, b"".join(parts))
        self.batches += 1

    def _read_loop(self) -> None:
        out = self._stdout
        try:
            while True:
                head = out.read(HEAD.size)
                if len(head) < HEAD.size:
                    break
                size, kind = HEAD.unpack(head)
                payload = out.read(size - 1)
                if len(payload) < size - 1:
                    break
                self._on_frame(kind, payload)
        finally:
            self.closed.set()

    def close(self, timeout: float = 5.0) -> None:
        """Send what waits, ask the ROS side to shut down, then make sure it is gone."""
        if self.process.poll() is None:
            self.send_control(op="shutdown")
            try:
                self._stdin.close()
            except (BrokenPipeError, OSError):
                pass
            try:
                self.process.wait(timeout)
            except subprocess.TimeoutExpired:
                self.process.kill()
                self.process.wait()
        self._reader.join(timeout)


def _widen(fd: int) -> None:
    """Give the pipe PIPE_BYTES of buffer where the system allows (Linux): a side that is off the CPU for a moment
    does not stop the sim at once (one that cannot keep up still does, when the pipe is full)."""
    set_size = getattr(fcntl, "F_SETPIPE_SZ", 1031)  # Linux's value; Python 3.10+ names it
    try:
        fcntl.fcntl(fd, set_size, PIPE_BYTES)
    except OSError:
        pass  # another system, or a lower /proc/sys/fs/pipe-max-size: the default buffer


class PipeEnd:
    """The side's end: reads on one thread, writes from any."""

    def __init__(self, inp: IO[bytes], out: IO[bytes]) -> None:
        self.inp, self.out = inp, out
        self.lock = threading.Lock()

    @classmethod
    def from_stdio(cls) -> PipeEnd:
        """The frames on stdin and stdout; whatever else writes to stdout (a library's prints) goes to stderr."""
        out = os.fdopen(os.dup(1), "wb")
        os.dup2(2, 1)
        return cls(os.fdopen(0, "rb", buffering=0), out)

    def send(self, kind: int, *parts: bytes | memoryview) -> None:
        """One frame."""
        size = 1 + sum(len(p) if not isinstance(p, memoryview) else p.nbytes for p in parts)
        with self.lock:
            self.out.write(HEAD.pack(size, kind))
            for part in parts:
                self.out.write(part)
            self.out.flush()

    def send_control(self, **fields: object) -> None:
        """A CONTROL frame."""
        self.send(CONTROL, pickle.dumps(fields, protocol=4))

    def frames(self, batch: bytes) -> list[tuple[int, memoryview]]:
        """The (kind, payload) frames inside a BATCH payload."""
        view, pos, out = memoryview(batch), 0, []
        while pos < len(view):
            size, kind = HEAD.unpack_from(view, pos)
            out.append((kind, view[pos + HEAD.size : pos + HEAD.size + size - 1]))
            pos += HEAD.size + size - 1
        return out

    def read(self) -> tuple[int, bytes] | None:
        """The next frame (kind, payload); None when the pipe closes."""
        head = self._exact(HEAD.size)
        if head is None:
            return None
        size, kind = HEAD.unpack(head)
        payload = self._exact(size - 1)
        return None if payload is None else (kind, payload)

    def _exact(self, n: int) -> bytes | None:
        chunks, left = [], n
        while left:
            chunk = self.inp.read(left)
            if not chunk:
                return None
            chunks.append(chunk)
            left -= len(chunk)
        return b"".join(chunks)
