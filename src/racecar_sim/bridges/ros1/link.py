"""The sim's end of the pipe to ros_side.py: framed writes, and a reader thread that hands frames on.

Frames are those of ros_side.py: uint32 length (little-endian) of what follows, one byte of kind, the payload;
CONTROL payloads are pickled dicts, DATA payloads a uint32 id and ROS 1 message bytes.
"""

from __future__ import annotations

import pickle
import struct
import subprocess
import threading
from collections.abc import Callable, Mapping, Sequence
from typing import Any

CONTROL, DATA = 0, 1
_HEAD = struct.Struct("<IB")
ID = struct.Struct("<I")


class RosSideLink:
    """The ROS side process and its pipe. `on_frame(kind, payload)` runs on the reader thread."""

    def __init__(self, command: Sequence[str], env: Mapping[str, str], on_frame: Callable[[int, bytes], None]) -> None:
        self.process = subprocess.Popen(
            list(command), stdin=subprocess.PIPE, stdout=subprocess.PIPE, env=dict(env), start_new_session=True
        )
        assert self.process.stdin is not None and self.process.stdout is not None  # both are PIPE
        self._stdin, self._stdout = self.process.stdin, self.process.stdout
        self._on_frame = on_frame
        self._lock = threading.Lock()
        self.closed = threading.Event()
        self._reader = threading.Thread(target=self._read_loop, name="ros1-bridge-reader", daemon=True)
        self._reader.start()

    def send(self, kind: int, *parts: bytes | memoryview) -> None:
        """One frame; `parts` are written back to back (no copy of a large message)."""
        size = 1 + sum(len(p) if not isinstance(p, memoryview) else p.nbytes for p in parts)
        stdin = self._stdin
        with self._lock:
            try:
                stdin.write(_HEAD.pack(size, kind))
                for part in parts:
                    stdin.write(part)
                stdin.flush()
            except (BrokenPipeError, ValueError):
                self.closed.set()

    def send_control(self, **fields: Any) -> None:
        self.send(CONTROL, pickle.dumps(fields, protocol=4))

    def _read_loop(self) -> None:
        out = self._stdout
        try:
            while True:
                head = out.read(_HEAD.size)
                if len(head) < _HEAD.size:
                    break
                size, kind = _HEAD.unpack(head)
                payload = out.read(size - 1)
                if len(payload) < size - 1:
                    break
                self._on_frame(kind, payload)
        finally:
            self.closed.set()

    def close(self, timeout: float = 5.0) -> None:
        """Ask the ROS side to shut down, then make sure it is gone."""
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
