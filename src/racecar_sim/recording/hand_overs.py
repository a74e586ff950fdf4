"""The writer process's data pipe: how a hand-over crosses it, the parent's writing (PipeBacklog) and the child's
reading of them from its first moment.

A hand-over is a head (the pickle's length, the number of out-of-band buffers), each buffer's length, the pickle, then
the buffers. This module imports nothing but the standard library, and the child (recording/writer_process.py) starts
reading with it before it imports the writer's modules (numpy, mcap, the message classes: ~0.13 s of CPU, more on a
busy core). A run whose loop starts sooner than that (one car in `empty` without the camera starts its loop ~40 ms
after it starts the child) filled the pipe and waited on it in its first hand-overs: 70-120 ms of a 1-car, 60 s
recorded run of ~1 s; 30-55 ms with the child reading first (its reader waits for the GIL that the imports hold); none
now that what the pipe cannot take waits in the parent.
"""

from __future__ import annotations

import contextlib
import itertools
import os
import queue
import select
import struct
import sys
import threading
from collections import deque
from collections.abc import Iterable
from typing import Any

HEAD = struct.Struct("<QI")  # pickle bytes, out-of-band buffers
SIZE = struct.Struct("<Q")
DEPTH = 64
"""Hand-overs the child may hold unwritten (with a frame each, two seconds of 30 Hz video); beyond that (and the pipe's
MB, and the parent's BACKLOG) the parent's send waits, so the simulation never runs far ahead of its files and memory
stays bounded."""
BACKLOG = 64 << 20
"""Bytes of hand-overs the parent may hold unwritten while the pipe is full (the child still importing, or behind):
the simulation runs on meanwhile. Beyond that, a hand-over waits for the pipe, as every one did before."""
IOV_MAX = 1024  # pieces os.writev takes at once (Linux's UIO_MAXIOV)
HandOver = tuple[memoryview, list[memoryview]]  # the pickle, its out-of-band buffers
HandOvers = queue.Queue[HandOver | None]  # None: the pipe's end


def framed(body: bytes, raws: list[memoryview]) -> list[memoryview]:
    """A hand-over's pieces as the parent writes them: the head and sizes, the pickle `body`, its buffers `raws`."""
    head = HEAD.pack(len(body), len(raws)) + b"".join(SIZE.pack(r.nbytes) for r in raws)
    return [memoryview(head), memoryview(body), *raws]


class PipeBacklog:
    """The parent's end of the data pipe (made non-blocking): hand-overs written as far as the pipe takes them, the rest
    kept in order and written by later hand-overs.

    A run whose loop starts before its child reads (a lone car in `empty` starts its loop ~40 ms after it starts the
    child, which reads slowly while its imports hold the GIL: ~0.15 s) used to wait on the full pipe: 30-55 ms of a
    1 s recorded run. Now it waits only beyond BACKLOG bytes, or where it must (write(wait=True): a reply awaited, a
    camera frame's slot awaited, the end). A piece left unwritten that is a view of memory the caller may change (an
    image's pixels) is copied first, so that what crosses later is what was handed over."""

    def __init__(self, fd: int) -> None:
        os.set_blocking(fd, False)
        self.fd = fd
        self.pieces: deque[memoryview] = deque()
        self.size = 0  # bytes in pieces

    def add(self, pieces: Iterable[memoryview]) -> None:
        """Queue a hand-over's pieces (framed()) after those already kept."""
        for piece in pieces:
            self.pieces.append(piece)
            self.size += piece.nbytes

    def write(self, wait: bool = False) -> None:
        """Write what the pipe takes now; with `wait` (or more than BACKLOG bytes kept), all of it, waiting for room.
        Raises BrokenPipeError where the child is gone."""
        pieces = self.pieces
        while pieces:
            try:
                written = os.writev(self.fd, list(itertools.islice(pieces, IOV_MAX)))
            except BlockingIOError:
                if not wait and self.size <= BACKLOG:
                    self._keep()
                    return
                select.select([], [self.fd], [])
                continue
            self.size -= written
            while written:
                if written >= pieces[0].nbytes:
                    written -= pieces.popleft().nbytes
                else:
                    pieces[0] = pieces[0][written:]
                    written = 0

    def clear(self) -> None:
        """Forget what is kept (the child is gone)."""
        self.pieces.clear()
        self.size = 0

    def _keep(self) -> None:
        for k, piece in enumerate(self.pieces):
            if not isinstance(piece.obj, bytes):  # an ndarray's memory: a camera may draw into it again
                self.pieces[k] = memoryview(piece.tobytes())


def begin_child() -> HandOvers:
    """The child's first step, before its imports: schedule the process as batch work and start reading the
    hand-overs from the data pipe (its fd is argv[1]) into the queue it returns, which serve() then takes."""
    _batch_scheduling()  # before any thread starts: a thread keeps the policy of the thread that started it
    hand_overs: HandOvers = queue.Queue(DEPTH)
    reader = threading.Thread(target=read_hand_overs, args=(int(sys.argv[1]), hand_overs), daemon=True)
    reader.start()  # reads on while the child imports, and later while it encodes: the parent waits on neither
    return hand_overs


def _batch_scheduling() -> None:
    """Schedule this process as batch work (Linux's SCHED_BATCH), before it starts any thread: a simulation thread that
    wakes (the GL thread with a frame to draw, the main thread with its frame drawn) does not wait behind it."""
    if hasattr(os, "sched_setscheduler") and hasattr(os, "SCHED_BATCH"):
        with contextlib.suppress(OSError):
            os.sched_setscheduler(0, os.SCHED_BATCH, os.sched_param(0))


def read_hand_overs(fd: int, hand_overs: HandOvers) -> None:
    """Put each hand-over read from `fd` into `hand_overs` (waiting while it holds DEPTH), then None at the pipe's
    end or at a hand-over cut off half-way (the parent died).

    A hand-over is read in three reads (its head, its sizes, the rest into one buffer, of which the pickle and the
    buffers are views), not one per buffer: each read gives up the GIL, and taking it back waits for the thread that
    holds it (the child's imports, then its encoding) for up to the interpreter's switch interval (5 ms)."""
    with open(fd, "rb", buffering=0) as pipe:
        while True:
            head = _read_into(pipe, bytearray(HEAD.size))
            if head is None:
                break
            body_size, count = HEAD.unpack(head)
            sizes = [size for (size,) in SIZE.iter_unpack(_read_into(pipe, bytearray(SIZE.size * count)) or b"")]
            rest = _read_into(pipe, bytearray(body_size + sum(sizes)))
            if len(sizes) != count or rest is None:
                break  # cut off: the parent died half-way through a hand-over
            view, start, buffers = memoryview(rest), body_size, []
            for size in sizes:
                buffers.append(view[start : start + size])
                start += size
            hand_overs.put((view[:body_size], buffers))
    hand_overs.put(None)


def _read_into(pipe: Any, buffer: bytearray) -> bytearray | None:
    view, done = memoryview(buffer), 0
    while done < len(buffer):
        got = pipe.readinto(view[done:])
        if not got:
            return None
        done += got
    return buffer
