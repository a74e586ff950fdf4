"""A writer thread: a run's files (MCAP chunks, JPEG images, the video) are written while the physics goes on.

The encoders it runs (zstd, libjpeg-turbo, x264) release the GIL, so on a machine with two cores the writing
overlaps the stepping instead of adding to it.
"""

from __future__ import annotations

import queue
import threading
from collections.abc import Callable

DEPTH = 64
"""Jobs that may wait (two seconds of 30 Hz frames): beyond that submit() waits, so the simulation never runs far
ahead of its files and memory stays bounded."""


def _STOP() -> None:
    """The job that ends the thread (a marker: never run)."""


class WriterThread:
    """Runs submitted jobs one after another, in submission order, on one background thread.

    Output is therefore the same as running them in place, byte for byte. At most `depth` jobs wait; submit()
    blocks beyond that. A job that raises stops the thread from running later jobs; the error is raised once, by
    the next submit() or by close(). close() runs every job submitted before it (a Ctrl-C meanwhile is held back
    until they are done, so an interrupted run still finishes its files) and is idempotent.
    """

    def __init__(self, name: str, depth: int = DEPTH) -> None:
        self.name = name
        self._queue: queue.Queue[Callable[[], object]] = queue.Queue(maxsize=depth)
        self._error: BaseException | None = None
        self._closed = False
        # daemon: a thread left running can never hold the interpreter's exit; close() is what waits for it
        self._thread = threading.Thread(target=self._run, name=name, daemon=True)
        self._thread.start()

    def submit(self, job: Callable[[], object]) -> None:
        """Queue `job()`; raises the error of an earlier job, or ValueError after close()."""
        if self._closed:
            raise ValueError(f"submit() after close() of the {self.name} writer")
        self._raise()
        self._queue.put(job)

    def _run(self) -> None:
        while True:
            job = self._queue.get()
            if job is _STOP:
                return
            if self._error is None:
                try:
                    job()
                except BaseException as exc:
                    self._error = exc

    def _raise(self) -> None:
        error = self._error
        if error is not None and not isinstance(error, _Reported):
            self._error = _Reported()  # later jobs still do not run
            raise error

    def close(self) -> None:
        """Run the jobs submitted so far, stop the thread, and raise the first job error not yet raised."""
        if not self._closed:
            self._closed = True
            interrupted = uninterrupted(lambda: self._queue.put(_STOP))
            interrupted |= uninterrupted(self._thread.join)
            if interrupted:
                self._raise()
                raise KeyboardInterrupt
        self._raise()


class _Reported(Exception):
    """Stands in for an error already raised: later jobs are skipped without raising it again."""


def uninterrupted(wait: Callable[[], object]) -> bool:
    """Call `wait()` to completion through any KeyboardInterrupt; whether one came."""
    interrupted = False
    while True:
        try:
            wait()
            return interrupted
        except KeyboardInterrupt:
            interrupted = True
