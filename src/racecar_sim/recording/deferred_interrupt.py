"""Ctrl-C held back while a writer's state is half-updated: the MCAP writer's indexes, a frame half-way through the
writer process's pipe. A module of its own, so that a recorded run's simulation process, which only hands over what it
publishes, does not import the MCAP writer."""

from __future__ import annotations

import signal
import threading
from collections.abc import Iterable
from types import FrameType
from typing import Any


class DeferredInterrupt:
    """Holds SIGINT (and any other `signums`) back while a writer's state is half-updated.

    A KeyboardInterrupt raised inside ``mcap.writer.Writer`` (for example right after a
    chunk was compressed but before it was written) would leave indexes pointing at lost
    data; one raised in the middle of a frame sent to a writer process would cut the
    frame. Between ``hold()`` and the matching ``release()`` on the main thread (they
    nest) the Python-level handlers only note the signal; the outermost ``release()``
    then delivers it to the previously installed handler. Installed only from the main
    thread and only over a callable handler; elsewhere every method is a no-op.
    """

    def __init__(self, signums: Iterable[int] = (signal.SIGINT,)) -> None:
        self._main = threading.main_thread().ident
        self._depth = 0
        self._pending: tuple[int, FrameType | None] | None = None
        self._previous: dict[int, Any] = {}
        if threading.get_ident() == self._main:
            for signum in signums:
                previous = signal.getsignal(signum)
                if callable(previous):
                    self._previous[signum] = previous
                    signal.signal(signum, self._handle)

    def _active(self) -> bool:
        # KeyboardInterrupt is only ever raised on the main thread.
        return bool(self._previous) and threading.get_ident() == self._main

    def _handle(self, signum: int, frame: FrameType | None) -> None:
        if self._depth:
            self._pending = (signum, frame)
        else:
            self._previous[signum](signum, frame)

    def hold(self) -> None:
        """Start (or nest) deferring the signals."""
        if self._active():
            self._depth += 1

    def release(self) -> None:
        """End one ``hold()``; the outermost delivers a signal that arrived meanwhile."""
        if not self._active():
            return
        self._depth -= 1
        if self._depth == 0 and self._pending is not None:
            pending, self._pending = self._pending, None
            self._previous[pending[0]](*pending)

    def uninstall(self) -> None:
        """Restore the previous handlers where ours are still the installed ones."""
        if self._active():
            for signum, previous in self._previous.items():
                if signal.getsignal(signum) == self._handle:
                    signal.signal(signum, previous)
