"""The writer process's data pipe: how a hand-over crosses it, and the child's reading of them from its first moment.

A hand-over is a head (the pickle's length, the number of out-of-band buffers), each buffer's length, the pickle, then
the buffers. This module imports nothing but the standard library, and the child (recording/writer_process.py) starts
reading with it before it imports the writer's modules (numpy, mcap, the message classes: ~0.13 s of CPU, more on a
busy core). A run whose loop starts sooner than that (one car in `empty` without the camera starts its loop ~40 ms
after it starts the child) filled the pipe and waited on it in its first hand-overs: 70-120 ms of a 1-car, 60 s
recorded run of ~1 s, 30-55 ms now (the reader still waits for the GIL that the imports hold).
"""

from __future__ import annotations

import contextlib
import os
import queue
import struct
import sys
import threading
from typing import Any

HEAD = struct.Struct("<QI")  # pickle bytes, out-of-band buffers
SIZE = struct.Struct("<Q")
DEPTH = 64
"""Hand-overs the child may hold unwritten (with a frame each, two seconds of 30 Hz video); beyond that the parent's
send waits, so the simulation never runs far ahead of its files and memory stays bounded."""
HandOver = tuple[memoryview, list[memoryview]]  # the pickle, its out-of-band buffers
HandOvers = queue.Queue[HandOver | None]  # None: the pipe's end


def framed(body: bytes, raws: list[memoryview]) -> list[memoryview]:
    """A hand-over's pieces as the parent writes them: the head and sizes, the pickle `body`, its buffers `raws`."""
    head = HEAD.pack(len(body), len(raws)) + b"".join(SIZE.pack(r.nbytes) for r in raws)
    return [memoryview(head), memoryview(body), *raws]


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
