"""The terminal side of `racecar-sim teleop`: raw keys without blocking, and signals that end a session."""

from __future__ import annotations

import codecs
import os
import re
import select
import signal
import sys
import termios
import tty
from types import FrameType
from typing import Any

# An arrow or function key arrives as ESC [ ... or ESC O x; taken apart, "\x1b[A" would read as an
# "a" (forward and left). Each such sequence counts as one key that is not bound: it stops the car.
_ESCAPE_SEQUENCE = re.compile(r"\x1b(?:\[[0-?]*[ -/]*[@-~]|O.)")
ESCAPE = "\x1b"


def stdin_is_tty() -> bool:
    """Whether standard input is an open terminal."""
    try:
        return sys.stdin is not None and os.isatty(sys.stdin.fileno())
    except (OSError, ValueError):  # stdin closed, or replaced by an object without a descriptor
        return False


class RawTerminal:
    """A TTY in raw mode for the life of a `with` block; its saved attributes come back however it ends.

    Input is raw as in keyboard_teleop.py (tty.setraw): one key at a time, no echo, and Ctrl-C arrives as
    the character "\\x03" instead of a SIGINT. Output processing stays on, so "\\n" still returns the
    carriage and a warning or log line printed meanwhile does not run off to the right.
    """

    def __init__(self, fd: int) -> None:
        self.fd = fd
        self._saved: list[Any] | None = None
        self._decoder = codecs.getincrementaldecoder("utf-8")(errors="replace")

    def __enter__(self) -> RawTerminal:
        self._saved = termios.tcgetattr(self.fd)
        try:
            tty.setraw(self.fd)
            mode = termios.tcgetattr(self.fd)
            mode[tty.OFLAG] |= termios.OPOST
            termios.tcsetattr(self.fd, termios.TCSADRAIN, mode)
        except BaseException:
            self.restore()
            raise
        return self

    def __exit__(self, *exc: object) -> None:
        self.restore()

    def restore(self) -> None:
        """Put back the attributes saved on entry (idempotent; quiet when the terminal has hung up)."""
        if self._saved is None:
            return
        try:
            termios.tcsetattr(self.fd, termios.TCSADRAIN, self._saved)
        except (termios.error, OSError):
            pass  # the terminal is gone: nothing left to restore
        self._saved = None

    def read_keys(self, timeout: float = 0.0) -> str:
        """Every key typed so far, waiting at most `timeout` s for the first; "" if none.

        Bytes that are not UTF-8 come back as U+FFFD and an escape sequence as a single ESC, both
        unbound keys. Raises EOFError when the terminal is closed or hung up.
        """
        keys = ""
        wait = max(0.0, timeout)
        while True:
            try:
                ready, _, _ = select.select([self.fd], [], [], wait)
                if not ready:
                    return _ESCAPE_SEQUENCE.sub(ESCAPE, keys)
                data = os.read(self.fd, 1024)
            except OSError:  # EIO: the other end of the terminal closed
                data = b""
            if not data:
                raise EOFError("the terminal closed")
            keys += self._decoder.decode(data)
            wait = 0.0


class StopSignals:
    """SIGINT, SIGTERM and SIGHUP from outside end the session in order instead of killing it.

    The first signal is only noted in `received` (the session loop checks it between slices and then
    stops the car, restores the terminal and closes the recording); a second one raises
    KeyboardInterrupt, which still unwinds through every `with` block. A signal ignored on entry stays
    ignored; the previous handlers come back on exit. `signals` narrows the set (`run` leaves SIGHUP alone).
    """

    SIGNALS = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)

    def __init__(self, signals: tuple[int, ...] = SIGNALS) -> None:
        self.received: int | None = None
        self._signals = signals
        self._previous: dict[int, Any] = {}

    def __enter__(self) -> StopSignals:
        for signum in self._signals:
            if signal.getsignal(signum) != signal.SIG_IGN:  # ignored on purpose (nohup, a background job)
                self._previous[signum] = signal.signal(signum, self._handle)
        return self

    def __exit__(self, *exc: object) -> None:
        for signum, handler in self._previous.items():
            signal.signal(signum, signal.SIG_DFL if handler is None else handler)  # None: set outside Python
        self._previous.clear()

    def _handle(self, signum: int, frame: FrameType | None) -> None:
        if self.received is not None:
            raise KeyboardInterrupt
        self.received = signum
