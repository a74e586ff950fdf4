"""A writer process: a run's files (MCAP chunks, JPEG images, the x264 video) are written by a child process.

The recording's Python (the mcap writer, chunking) and the encoders would otherwise compete with the simulation for
its GIL. The parent only hands over what it publishes, in batches through a pipe: messages already serialized, and
camera images as their raw pixels, sent once even when the child both records them as JPEG and puts them in the
video (a camera frame through shared memory where the system has it: one copy instead of the pipe's two, and none
of the child's allocations). The child does the work in the order it was handed over, so the files are byte for byte
those writing in place gives. The child is a fresh interpreter (like multiprocessing's spawn, never a fork of a
process with GL contexts and threads) started without waiting for it: its imports overlap the parent's start-up.
"""

from __future__ import annotations

import contextlib
import fcntl
import gc
import logging
import mmap
import os
import pickle
import select
import signal
import socket
import subprocess
import sys
import threading
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from racecar_sim.bus import RowPacker
from racecar_sim.core.errors import RecordingError
from racecar_sim.msgs import Image
from racecar_sim.recording.deferred_interrupt import DeferredInterrupt
from racecar_sim.recording.hand_overs import SIZE, HandOver, HandOvers, PipeBacklog, framed
from racecar_sim.recording.writer_thread import uninterrupted

BATCH = 256
"""Operations per hand-over: one pipe write per message would cost more than most messages' writing. An operation
with an image's pixels is handed over at once, so that a hand-over holds at most one frame."""
PIPE_SIZE = 1 << 20  # bytes: a camera frame fits in the pipe at once (Linux's default limit for a user)
RING_SLOTS = 32
"""Camera frames the shared memory holds (a second of 30 Hz video, 29 MB at 640x480): the parent writes frame n in
slot n % RING_SLOTS once the child has let go of the frame RING_SLOTS before, waiting (RING_WAIT at a time) when the
child is that far behind."""
GIVE_WAY = 5
"""Nice levels the child's relaxed worker runs below the simulation (_Workers); 3 and 10 gave less than 5."""
BEHIND, CAUGHT_UP = 24, 8
"""Hand-overs waiting at which the urgent worker takes over from the relaxed one, and at which it hands back: about
24 and 8 frames (a frame is about one hand-over), inside the frame ring's RING_SLOTS."""
OUT_OF_BAND = 4096
"""bytes: a message at least this long (a scan) crosses the pipe beside the hand-over's pickle, not copied into it."""
RING_MIN = 1 << 16  # bytes: smaller images cross in the pipe (they cost little there), and so do the first's larger
RING_WAIT = 0.0005  # s
_RING_HEAD = 64  # bytes before the slots: the first 8, the number of the first frame the child still holds

_SIGNALS = (signal.SIGINT, signal.SIGTERM)
_PR_SET_PDEATHSIG = 1  # linux/prctl.h

# operations, the first item of each tuple handed over
MESSAGE, JPEG, FRAME, OPEN_MCAP, OPEN_VIDEO, CLOSE_VIDEO, PACKER, ROWS = range(8)
_SAME = None  # an image op's pixels: those of the image before
_RING = "ring"  # an image's pixels in the shared memory: (_RING, frame number, bytes, slot size, slots)


class WriterProcess:
    """The parent's end of a child process that writes a run's files; see the module docstring.

    Operations are queued with `message()`, `image()` and `send()` and handed over BATCH at a time. An error in the
    child (disk full, a failing encoder) stops it from doing later operations; it is raised once, by a later
    hand-over or by close(). A child that died is such an error too, never a hang. close() hands over everything
    queued, lets the child finish its files and waits for it to exit; a Ctrl-C or SIGTERM meanwhile is held back
    until then, so an interrupted run still finishes its files. The child ignores SIGINT and SIGTERM: a Ctrl-C
    reaches the whole process group, and the parent's close() is what ends it.

    `pass_fds`: the parent's open files the child uses, named in operations by their numbers here (pass_fds()).
    `colour`: the child loads the compiled colour conversion (recording/colour.py: numba, ~0.45 s of CPU) as it
    starts, and an MP4 it writes takes its frames from it (one conversion for the JPEG and the video); for a process
    started before the run, where the load is free (start_early()). open() takes the process start_early() started,
    if one waits.
    """

    def __init__(self, name: str, pass_fds: Sequence[int] = (), colour: bool = False) -> None:
        self.name = name
        self.results: dict[str, Any] = {}
        self._ops: list[tuple[Any, ...]] = []
        self._packers: dict[object, int] = {}  # what packs rows() -> its number in the child (handed over once)
        self._last_image: object = None
        self._pixels_queued = False  # an op with an image's pixels waits: hand it over with the op that takes it
        self._error: BaseException | None = None
        self._reported = False
        self._closed = False
        data_read, data_write = os.pipe()
        self._data: int | None = data_write
        back_read, back_write = os.pipe()
        with contextlib.suppress(OSError, AttributeError):  # a bigger pipe: fewer wake-ups per frame
            fcntl.fcntl(data_write, fcntl.F_SETPIPE_SZ, PIPE_SIZE)
        self._ring_fd = _shared_memory()  # sized with the first camera frame
        self._ring: _FrameRing | None = None
        ring_fds = () if self._ring_fd is None else (self._ring_fd,)
        self._fds, fds_child = socket.socketpair(socket.AF_UNIX, socket.SOCK_DGRAM)  # pass_fds: files sent later
        # a SIGKILL of the run ends its writer too (on Linux): the file is cut where it was, as without a process
        # (racecar-sim recover mends it), never finished behind the back of whoever reads it next. Only when the
        # main thread starts it: the signal comes when the starting thread ends.
        linked = os.getpid() if threading.current_thread() is threading.main_thread() else 0
        command = [
            sys.executable,
            "-c",
            # the cyclic collector off while the modules load, until _import_encoders froze what they made; once
            # serve() reported its files finished, the child leaves without the interpreter's teardown (its
            # modules' and objects' clean-up: 50-80 ms of CPU that the parent's close() would wait for)
            "import gc; gc.disable(); from racecar_sim.recording.hand_overs import begin_child; h = begin_child(); "
            "from racecar_sim.recording.writer_process import serve; serve(h); import os; os._exit(0)",
            str(data_read),
            str(back_write),
            str(linked),
            str(-1 if self._ring_fd is None else self._ring_fd),
            str(fds_child.fileno()),
            str(int(colour)),
        ]
        # the child starts with SIGINT and SIGTERM blocked, so none arrives before it ignores them
        blocked = signal.pthread_sigmask(signal.SIG_BLOCK, _SIGNALS)
        try:
            self._process = subprocess.Popen(
                command,
                pass_fds=(data_read, back_write, *ring_fds, fds_child.fileno()),
                stdin=subprocess.DEVNULL,
                env=_child_environment(),
            )
        except BaseException:
            for fd in (data_write, back_read, *ring_fds):
                os.close(fd)
            self._fds.close()
            raise
        finally:
            signal.pthread_sigmask(signal.SIG_SETMASK, blocked)
            os.close(data_read)
            os.close(back_write)
            fds_child.close()
        self._back: int | None = back_read
        self._backlog = PipeBacklog(data_write)  # hand-overs the pipe has not taken yet
        self._interrupt = DeferredInterrupt(_SIGNALS)
        self.pass_fds(pass_fds)

    @classmethod
    def open(cls, name: str, pass_fds: Sequence[int] = ()) -> WriterProcess:
        """A writer process for `name`: the one start_early() started, if it waits unused, else a new one."""
        global _early
        process, _early = _early, None
        if process is None or process.closed:
            return cls(name, pass_fds)
        process.name = name
        process.pass_fds(pass_fds)
        return process

    def pass_fds(self, fds: Sequence[int]) -> None:
        """Send the child copies of the parent's open files `fds`, which operations name by the parent's numbers (a
        recording opened here, so that a path that cannot be written raises at once in the caller); the caller
        closes its own copies afterwards. A child already running gets them too: they cross the socket with the
        numbers they have here."""
        if fds:
            socket.send_fds(self._fds, [SIZE.pack(len(fds)) + b"".join(SIZE.pack(fd) for fd in fds)], list(fds))

    def message(self, topic: str, msgtype: str, data: bytes, log_time_ns: int) -> None:
        """Record a serialized message (CDR bytes of type `msgtype`, `pkg/msg/Name`) at `log_time_ns`."""
        # a long one is written to the pipe from where it is: the child gets a view of it (bytes again in do_all)
        payload = data if len(data) < OUT_OF_BAND else pickle.PickleBuffer(data)
        self._ops.append((MESSAGE, topic, msgtype, payload, log_time_ns))
        if len(self._ops) >= BATCH:
            self.flush()

    def rows(
        self, msgtype: str, packer: RowPacker, topics: tuple[str, ...], rows: list[tuple[Any, ...]], log_time_ns: int
    ) -> None:
        """message() of each of `topics`, in order, all of type `msgtype` at `log_time_ns`, the k-th message's bytes
        being packer.pack_many(rows)[k]: the child packs them. `packer` (a msgs.CdrLayout or FilledLayout, which
        pickle as what makes them) is handed over once; it must keep packing the same bytes for the same numbers."""
        number = self._packers.get(packer)
        ops = self._ops
        if number is None:
            number = self._packers[packer] = len(self._packers)
            ops.append((PACKER, number, packer))
        ops.append((ROWS, number, msgtype, topics, rows, log_time_ns))
        if len(ops) >= BATCH:
            self.flush()

    def image(self, msg: Image) -> tuple[Any, ...] | None:
        """`msg` as an op's image: its pixels, or _SAME when it is the last image handed over (the child keeps it)."""
        if msg is self._last_image:
            return _SAME
        self._last_image = msg
        self._pixels_queued = True
        data = memoryview(msg.data)  # type: ignore[arg-type]  # an ndarray is a buffer: its stubs do not say so
        pixels: object = self._in_ring(data)
        if pixels is None:
            pixels = pickle.PickleBuffer(data if data.c_contiguous else data.tobytes())  # crosses the pipe uncopied
        return (msg.header, msg.height, msg.width, msg.encoding, msg.is_bigendian, msg.step, pixels)

    def _in_ring(self, data: memoryview) -> tuple[Any, ...] | None:
        """The pixels copied into the shared memory, as an image op's pixels; None where they go by the pipe."""
        if self._ring_fd is None or data.nbytes < RING_MIN or not data.c_contiguous:
            return None
        if self._ring is None:
            try:
                self._ring = _FrameRing(self._ring_fd, data.nbytes)
            except OSError:  # no room for it (e.g. a small /dev/shm): the pipe it is
                os.close(self._ring_fd)
                self._ring_fd = None
                return None
        ring = self._ring
        if data.nbytes > ring.slot_size:
            return None
        while not ring.free():  # the child is a second of frames behind: wait for it, as the pipe would
            self._hand_over(wait=True)  # what it needs to get there
            self._poll()
            if self._error is not None or self._back is None:
                return None  # the child does no more work: the next hand-over raises why
            time.sleep(RING_WAIT)
        return ring.put(data)

    def send(self, op: tuple[Any, ...], flush: bool = False) -> None:
        """Queue `op` (the operations above); `flush`: hand it over now."""
        self._ops.append(op)
        if flush or self._pixels_queued or len(self._ops) >= BATCH:
            self._pixels_queued = False
            self.flush()

    def flush(self, wait: bool = False) -> None:
        """Hand over the queued operations (those the pipe has no room for yet are kept, in order: PipeBacklog; `wait`:
        until the pipe took them all); raises an error the child met before (not yet raised)."""
        if self._closed:
            raise ValueError(f"hand-over after close() of the {self.name} writer process")
        self._poll()
        self._raise()
        self._hand_over(wait)
        self._raise()

    def _hand_over(self, wait: bool = False) -> None:
        self._interrupt.hold()  # a hand-over cut half-way would garble every one after it
        try:
            if self._ops:
                ops, self._ops = self._ops, []
                buffers: list[pickle.PickleBuffer] = []
                body = pickle.dumps(ops, 5, buffer_callback=buffers.append)
                self._backlog.add(framed(body, [b.raw() for b in buffers]))
            self._write_pending(wait)
        finally:
            self._interrupt.release()

    def _write_pending(self, wait: bool) -> None:
        assert self._data is not None, "a hand-over after the data pipe was closed"
        try:
            self._backlog.write(wait)
        except BrokenPipeError:
            self._backlog.clear()
            self._ops = []
            self._read_back(until="closed")  # its error, if it reported one before it died
            self._died()

    def request(self, op: tuple[Any, ...]) -> Any:
        """Hand over `op` and what is queued, and wait for the child's reply to it (after all the work before)."""
        self._ops.append(op)
        self._pixels_queued = False
        self.flush(wait=True)  # all of it in the pipe: the child replies after the work before
        reply = self._read_back(until="reply") if self._error is None else None
        self._raise()  # a child that met an error does no later operation, and so never replies
        return reply

    def _poll(self) -> None:
        """Read what the child reported, without waiting."""
        while self._back is not None and select.select([self._back], [], [], 0)[0]:
            if self._read_back(until=None) is None and self._back is None:
                return

    def _read_back(self, until: str | None) -> Any:
        """Read the child's reports (logs, errors, replies) up to one of kind `until` (None: one report)."""
        while self._back is not None:
            self._interrupt.hold()  # a report read half-way, or read and not taken in, would be lost
            try:
                kind, value = self._take_report()
            finally:
                self._interrupt.release()
            if kind is None or until is None or kind in (until, "error"):
                return value
        return None

    def _take_report(self) -> tuple[str | None, Any]:
        assert self._back is not None
        size = _read_exactly(self._back, SIZE.size)
        if not size:  # the child exited
            os.close(self._back)
            self._back = None
            self._died()
            return None, None
        kind, value = pickle.loads(_read_exactly(self._back, SIZE.unpack(size)[0]))
        if kind == "log":
            logging.getLogger(value[0]).log(value[1], "%s", value[2])
        elif kind == "error" and self._error is None:
            self._error = value
        elif kind == "closed":
            self.results = value
        return kind, value

    def _died(self) -> None:
        """The child is gone: wait for it, and make its end an error unless it had reported one or finished."""
        code = self._process.wait()
        if self._error is None and not self.results:
            self._error = RecordingError(
                f"{self.name}: the writer process exited (code {code}) before the files were finished"
            )

    def _raise(self) -> None:
        if self._error is not None and not self._reported:
            self._reported = True
            raise self._error

    def close(self) -> dict[str, Any]:
        """Hand over what is queued, let the child finish its files and exit, and raise its error not yet raised.
        Returns what the child reported at the end (e.g. the video's path). Idempotent."""
        if not self._closed:
            self._closed = True
            interrupted = uninterrupted(self._finish)
            self._interrupt.uninstall()
            if interrupted:
                self._raise()
                raise KeyboardInterrupt
        self._raise()
        return self.results

    def _finish(self) -> None:
        if self._data is not None:
            self._poll()
            if self._error is None:
                self._hand_over(wait=True)
            os.close(self._data)  # EOF: the child finishes its files and exits
            self._data = None
            self._backlog.clear()  # what a child that met an error (or died) will never read
        while self._back is not None and not self.results:
            self._read_back(until="closed")
        self._process.wait()
        if self._back is not None:
            os.close(self._back)
            self._back = None
        self._fds.close()
        if self._ring is not None:
            self._ring.close()
        if self._ring_fd is not None:
            os.close(self._ring_fd)
            self._ring_fd = None

    def abandon(self) -> None:
        """End a process that was handed no operation: its child killed and waited for, the pipes closed."""
        if self._closed:
            return
        self._closed = True
        self._interrupt.uninstall()
        self._process.kill()
        self._process.wait()
        for fd in (self._data, self._back, self._ring_fd):
            if fd is not None:
                os.close(fd)
        self._data = self._back = self._ring_fd = None
        self._fds.close()

    @property
    def closed(self) -> bool:
        """Whether close() has run."""
        return self._closed


def _read_exactly(fd: int, size: int) -> bytes:
    """`size` bytes from `fd`, or b"" at an end of file before them."""
    chunks = []
    while size:
        chunk = os.read(fd, size)
        if not chunk:
            return b""
        chunks.append(chunk)
        size -= len(chunk)
    return b"".join(chunks)


def _shared_memory() -> int | None:
    """An anonymous shared-memory file for camera frames (Linux's memfd), or None where there is none."""
    try:
        return os.memfd_create("racecar-sim frames")
    except (AttributeError, OSError):
        return None


_early: WriterProcess | None = None  # start_early()'s process, until WriterProcess.open() takes it


def start_early(colour: bool = False) -> None:
    """Start a writer process now, for the next WriterProcess.open() to take: its child's interpreter and imports
    (its modules and the encoders': ~0.3 s of CPU; with `colour`, the compiled colour conversion too: ~0.45 s more)
    then run beside the caller's own start (building a simulation, on one core), not beside the run that the files
    record. The process is closed by close_early() if none takes it."""
    global _early
    if _early is None:
        with contextlib.suppress(OSError):  # no process: WriterProcess.open() tries again, and falls back as before
            _early = WriterProcess("writer process started early", colour=colour)


def close_early() -> None:
    """End the process start_early() started, if nothing took it: it was given no file, so its child is killed
    rather than waited for (it may still be importing: a run whose build failed exits at once)."""
    global _early
    process, _early = _early, None
    if process is not None:
        process.abandon()


class _FrameRing:
    """The parent's end of the shared memory: RING_SLOTS slots of `slot_size` bytes after a head whose first 8 bytes
    the child writes: the number of the first frame it still holds (every frame before it is done with)."""

    def __init__(self, fd: int, slot_size: int) -> None:
        self.slot_size, self.slots = slot_size, RING_SLOTS
        size = _RING_HEAD + self.slots * slot_size
        os.ftruncate(fd, size)
        self.map = mmap.mmap(fd, size)
        self.held = np.ndarray((1,), np.uint64, self.map)  # the child's count
        self.bytes = np.ndarray((size,), np.uint8, self.map)  # numpy copies a frame in without holding the GIL
        self.next = 0  # the number of the next frame

    def free(self) -> bool:
        """Whether the next frame's slot is free: the child let go of the frame that was in it."""
        return self.next < self.slots or int(self.held[0]) > self.next - self.slots

    def put(self, data: memoryview) -> tuple[Any, ...]:
        """Copy a frame into the next slot; the image op's pixels that name it."""
        start = _RING_HEAD + (self.next % self.slots) * self.slot_size
        self.bytes[start : start + data.nbytes] = np.frombuffer(data, np.uint8)
        self.next += 1
        return (_RING, self.next - 1, data.nbytes, self.slot_size, self.slots)

    def close(self) -> None:
        del self.held, self.bytes
        self.map.close()


def _child_environment() -> dict[str, str]:
    """The parent's environment, with this racecar_sim first on the path (a checkout run by PYTHONPATH too), and
    numpy's OpenBLAS without threads of its own: the writer does no linear algebra, and its threads, started with
    numpy's import, would be the only ones not scheduled as batch work."""
    env = dict(os.environ)
    root = str(Path(__file__).resolve().parents[2])
    env["PYTHONPATH"] = os.pathsep.join(p for p in (root, env.get("PYTHONPATH")) if p)
    env["OPENBLAS_NUM_THREADS"] = "1"
    return env


class ProcessVideo:
    """camera.mp4 encoded by a WriterProcess: VideoWriter's interface for the images of a camera topic.

    write_image(msg) hands the image over (its pixels cross once when the recording has them too); close() waits
    for the child to finish the file and returns its path (.gif when the child fell back to the GIF preview).
    `owns_process`: close() closes the process too (a video without a recording).
    """

    def __init__(
        self, process: WriterProcess, path: str | Path, fps: float, width: int, height: int, owns_process: bool = False
    ) -> None:
        self.process = process
        self.path = Path(path)
        self.frames = 0
        self._owns = owns_process
        self._closed = False
        process.send((OPEN_VIDEO, str(self.path), float(fps), int(width), int(height)))

    def write_image(self, msg: Image) -> None:
        """Append the frame of a bgr8 / rgb8 Image."""
        if self._closed:
            raise ValueError(f"write() after close() of {self.path}")
        self.process.send((FRAME, self.process.image(msg)))
        self.frames += 1

    def close(self) -> Path:
        """Finish the file; returns the path written. Idempotent."""
        if not self._closed:
            self._closed = True
            if self._owns or self.process.closed:
                results = self.process.close()
            else:
                results = {"video": self.process.request((CLOSE_VIDEO,))}
            if results.get("video"):
                self.path = Path(results["video"])
        return self.path


# ---- the child ----


def _give_way() -> bool:
    """Lower the calling thread's priority by GIVE_WAY nice levels; whether it was lowered for this thread alone
    (Linux, where a nice value is a thread's), so that a thread started before keeps its priority."""
    if not sys.platform.startswith("linux"):
        return False
    try:
        os.setpriority(os.PRIO_PROCESS, threading.get_native_id(), os.getpriority(os.PRIO_PROCESS, 0) + GIVE_WAY)
    except OSError:
        return False
    return True


class _Workers:
    """The child's two workers, which take turns doing the hand-overs, in order, one at a time.

    The relaxed worker runs GIVE_WAY nice levels below the simulation: while the writer keeps up, the simulation's
    threads (stepping, drawing the next frame) get a core the moment they want one, and the encoding fills the gaps
    (4-8 % faster on 2 cores, interleaved rounds). When the hand-overs waiting reach BEHIND (the machine is busy with
    other work, and a nicer writer would starve: the simulation would wait on the frame ring), the urgent worker, at
    the simulation's priority, takes over until CAUGHT_UP."""

    def __init__(self, hand_overs: HandOvers, files: _Files) -> None:
        self.hand_overs, self.files = hand_overs, files
        self.turn = threading.Condition()
        self.urgent_turn = False
        self.finished = False
        self.error: BaseException | None = None
        self.done = {False: 0, True: 0}  # hand-overs done by the relaxed and the urgent worker

    def work(self, urgent: bool) -> None:
        """Do the hand-overs while it is this worker's turn, until the end of the pipe (or an error that escapes
        _do, e.g. the report pipe gone: then the other worker stops too, rather than wait for a turn forever)."""
        with self.turn:
            try:
                while True:
                    while self.urgent_turn != urgent and not self.finished:
                        self.turn.wait()
                    if self.finished:
                        return
                    hand_over = self.hand_overs.get()  # holding the turn: the other worker waits for it anyway
                    if hand_over is None:
                        return
                    self._do(hand_over)
                    self.done[urgent] += 1
                    waiting = self.hand_overs.qsize()
                    behind = waiting >= BEHIND or (self.urgent_turn and waiting > CAUGHT_UP)
                    if behind != self.urgent_turn:
                        self.urgent_turn = behind
                        self.turn.notify_all()
            finally:
                self.finished = True
                self.turn.notify_all()

    def _do(self, hand_over: HandOver) -> None:
        if self.error is not None:
            return  # later operations are not done, but read on: the parent never waits on a pipe nobody reads
        try:
            body, buffers = hand_over
            self.files.do_all(pickle.loads(body, buffers=buffers))
        except BaseException as exc:
            self.error = exc
            self.files.reports.send("error", exc)


def serve(hand_overs: HandOvers) -> None:
    """The child's main: do the operations begin_child() reads from the pipe (fd argv[1]) into `hand_overs`, until
    its end; report on fd argv[2]."""
    for signum in _SIGNALS:
        signal.signal(signum, signal.SIG_IGN)
    signal.pthread_sigmask(signal.SIG_UNBLOCK, _SIGNALS)
    parent = int(sys.argv[3])
    if parent and sys.platform.startswith("linux"):
        import ctypes

        ctypes.CDLL(None, use_errno=True).prctl(_PR_SET_PDEATHSIG, signal.SIGKILL)
        if os.getppid() != parent:  # it died before that
            os._exit(1)
    back = _Reports(int(sys.argv[2]))
    ring = int(sys.argv[4]) if len(sys.argv) > 4 else -1
    fds = socket.socket(fileno=int(sys.argv[5])) if len(sys.argv) > 5 else None
    colour = len(sys.argv) > 6 and sys.argv[6] == "1"
    logging.getLogger("racecar_sim").addHandler(back)
    workers = _Workers(hand_overs, _Files(back, ring, fds, colour))
    urgent = threading.Thread(target=workers.work, args=(True,), name="urgent writer", daemon=True)
    urgent.start()  # before this thread gives way: it keeps the simulation's priority
    # so do the imports: on a busy machine, at the relaxed worker's priority, they were still going on (and numba's
    # load with them) when the run began
    global _imports
    _imports = threading.Thread(target=_import_encoders, args=(colour,), name="imports", daemon=True)
    _imports.start()
    if _give_way():
        workers.work(urgent=False)
    else:  # a nice value for the whole process: one worker, at the simulation's priority
        with workers.turn:
            workers.urgent_turn = True
            workers.turn.notify_all()
    urgent.join()
    try:
        workers.files.close()
    except BaseException as exc:
        if workers.error is None:
            back.send("error", exc)
    back.send("closed", workers.files.results())


_imports: threading.Thread | None = None  # serve()'s thread running _import_encoders


def _import_encoders(colour: bool) -> None:
    """Import what the operations use (the MCAP writer, PyAV, simplejpeg, serialization; with `colour`, the compiled
    colour conversion) while the parent starts, rather than with the first operation of each kind, in the middle of
    a run (an import the first operation meets half-done waits for it); then freeze what exists and turn the cyclic
    collector back on (the child's command turned it off before its first import).

    The imports make some 10^5 objects that live as long as the process (numba's load most of them). With the
    collector on, it walked them again and again while they were made, and once more in a full collection soon after:
    0.13-0.14 s of the writer's CPU in a main job's start (1-2 ms frozen), while the simulation's process starts on
    the other core of a 2-core machine.
    Frozen (gc.freeze), they are out of the way of every later collection; the run's own garbage is collected as
    before. As the CLI does for the simulation's process (cli/collector.py)."""
    try:
        _import(colour)
    finally:
        gc.freeze()
        gc.enable()


def _import(colour: bool) -> None:
    with contextlib.suppress(Exception):  # an encoder missing: the operation that needs it says so, as before
        import av  # noqa: F401
        import simplejpeg  # noqa: F401

        import racecar_sim.recording.images
        import racecar_sim.recording.video  # noqa: F401
        from racecar_sim.msgs import serialize  # noqa: F401
        from racecar_sim.recording.mcap_recorder import McapRecorder  # noqa: F401
    if colour:
        from racecar_sim.recording.colour import load_kernel

        load_kernel()


class _Reports(logging.Handler):
    """The child's reports to the parent: log records of racecar_sim's loggers, its error, its results."""

    def __init__(self, fd: int) -> None:
        super().__init__(logging.INFO)
        self.fd = fd
        self.lock_ = threading.Lock()

    def send(self, kind: str, value: Any) -> None:
        try:
            data = pickle.dumps((kind, value))
        except Exception:
            data = pickle.dumps((kind, RecordingError(f"{type(value).__name__}: {value}")))
        with self.lock_:
            os.write(self.fd, SIZE.pack(len(data)) + data)

    def emit(self, record: logging.LogRecord) -> None:
        self.send("log", (record.name, record.levelno, record.getMessage()))


class _Files:
    """The child's files: the MCAP recorder and the video writer, opened by operations."""

    def __init__(
        self, reports: _Reports, ring_fd: int = -1, fds: socket.socket | None = None, colour: bool = False
    ) -> None:
        self.reports = reports
        self.colour = colour  # an MP4 takes its frames from the compiled colour conversion (WriterProcess's)
        self.fds = fds  # the parent's pass_fds() arrive here
        self.passed: dict[int, int] = {}  # the parent's number of a file passed -> the child's
        self.recorder: Any = None
        self.video: Any = None
        self.video_path: str | None = None
        self.last_image: Image | None = None
        self.ring_fd = ring_fd
        self.ring: mmap.mmap | None = None  # the shared memory, mapped with the first frame in it
        self.held: np.ndarray | None = None  # its head's count: the parent's _FrameRing.held
        self.holding: int | None = None  # the frame of the shared memory last_image is
        self.planes: Any = None  # colour.CameraPlanes while an MP4 is written: a frame converted once for both
        self.packers: dict[int, Any] = {}  # what packs ROWS ops' messages, by the number the parent gave it

    def image(self, pixels: tuple[Any, ...] | None) -> Image:
        if pixels is not _SAME:
            header, height, width, encoding, is_bigendian, step, data = pixels
            self.last_image = None
            if self.holding is not None:  # the image before is done with: its slot is the parent's again
                assert self.held is not None
                self.held[0] = self.holding + 1
                self.holding = None
            if isinstance(data, tuple) and data[0] == _RING:
                data = self._from_ring(*data[1:])
            self.last_image = Image(header, height, width, encoding, is_bigendian, step, data)
        assert self.last_image is not None
        return self.last_image

    def _from_ring(self, frame: int, nbytes: int, slot_size: int, slots: int) -> memoryview:
        if self.ring is None:
            self.ring = mmap.mmap(self.ring_fd, _RING_HEAD + slots * slot_size)
            self.held = np.ndarray((1,), np.uint64, self.ring)
        self.holding = frame
        start = _RING_HEAD + (frame % slots) * slot_size
        return memoryview(self.ring)[start : start + nbytes]

    def passed_fd(self, fd: int) -> int:
        """The child's copy of the parent's file `fd` (WriterProcess.pass_fds), which the parent sent before the
        operation that names it."""
        while fd not in self.passed:
            if self.fds is None:
                return fd  # a parent of the same code always sends them; a child started without the socket inherits
            data, fds, _, _ = socket.recv_fds(self.fds, SIZE.size * 64, 64)
            numbers = [number for (number,) in SIZE.iter_unpack(data[SIZE.size :])]
            self.passed.update(zip(numbers, fds))
        return self.passed.pop(fd)

    def do_all(self, ops: list[tuple[Any, ...]]) -> None:
        """do() each op in turn; a run of messages (rows packed here) goes to the recorder at once
        (McapRecorder.write_many)."""
        run: list[tuple[Any, ...]] = []
        for op in ops:
            kind = op[0]
            if kind == MESSAGE:
                if type(op[3]) is not bytes:  # a long message's bytes, read beside the pickle (OUT_OF_BAND)
                    op = (kind, op[1], op[2], bytes(op[3]), op[4])
                run.append(op[1:])
            elif kind == ROWS:
                run.extend(self.packed(op))
            else:
                if run:
                    self.recorder.write_many(run)
                    run = []
                self.do(op)
        if run:
            self.recorder.write_many(run)

    def packed(self, op: tuple[Any, ...]) -> list[tuple[str, str, bytes, int]]:
        """A ROWS op's messages, (topic, msgtype, CDR bytes, log time) each, packed by the packer it names."""
        _, number, msgtype, topics, rows, log_time = op
        return [(topic, msgtype, data, log_time) for topic, data in zip(topics, self.packers[number].pack_many(rows))]

    def do(self, op: tuple[Any, ...]) -> None:
        kind = op[0]
        if kind == MESSAGE:
            self.recorder.write_serialized(op[1], op[2], bytes(op[3]), op[4])
        elif kind == ROWS:
            self.recorder.write_many(self.packed(op))
        elif kind == PACKER:
            self.packers[op[1]] = op[2]
        elif kind == JPEG:
            from racecar_sim.msgs import serialize

            _, topic, msgtype, pixels, log_time, quality = op
            image = self.image(pixels)
            if self.planes is None:
                from racecar_sim.recording.images import compress_image

                compressed = compress_image(image, quality)
            else:
                compressed = self.planes.compressed(image, self.video, quality)
            self.recorder.write_serialized(topic, msgtype, serialize(compressed), log_time)
        elif kind == FRAME:
            try:
                image = self.image(op[1])
                frame = None if self.planes is None else self.planes.video_frame(image, self.video)
                if frame is None:
                    self.video.write(image.bgr_pixels())
                else:
                    self.video.write_yuv420p(frame)
            except OSError as exc:  # a full disk, a file size limit: one line, not the encoder's traceback
                raise RecordingError(
                    f"{self.video_path}: the video stopped: cannot write the file ({exc.strerror or exc})"
                ) from None
        elif kind == OPEN_MCAP:
            from racecar_sim.recording.mcap_recorder import McapRecorder

            _, fd, path, compression = op
            self.recorder = McapRecorder(path, compression=compression, stream=open(self.passed_fd(fd), "wb"))
        elif kind == OPEN_VIDEO:
            if _imports is not None:
                # PyAV's import may be failing in the imports thread (no PyAV: the GIF fallback), and a concurrent
                # `import av` can then return the half-made module (CPython's import fast path): its outcome first
                _imports.join()
            from racecar_sim.recording.video import VideoWriter

            self.video = VideoWriter(*op[1:])
            self.video_path = str(self.video.path)
            if self.colour and self.video.takes_yuv420p:
                # one conversion for the JPEG and the video: it pays only where it saves libswscale's (~0.4 ms of
                # the 1.3 ms the encoders spent converting a 640x480 frame), and where numba's load (~0.45 s) was
                # done beside the parent's start. Waited for if still loading: every frame of the video then comes
                # the same way, so that a run's camera.mp4 is the same bytes every time.
                from racecar_sim.recording.colour import CameraPlanes

                self.planes = CameraPlanes()
        elif kind == CLOSE_VIDEO:
            self.close_video()
            self.reports.send("reply", self.video_path)

    def close_video(self) -> None:
        if self.video is not None:
            video, self.video, self.planes = self.video, None, None
            if video.frames:
                video.close()
            else:  # no frame, no file: nothing was muxed
                with contextlib.suppress(Exception):
                    video.close()

    def close(self) -> None:
        try:
            self.close_video()
        finally:
            if self.recorder is not None:
                self.recorder.close()

    def results(self) -> dict[str, Any]:
        counts = self.recorder.message_count if self.recorder is not None else {}
        return {"video": self.video_path, "counts": counts}
