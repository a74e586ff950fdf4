"""A recording's file, opened and held exclusively before anything is written to it, and the one-line errors of a
file that cannot be had. A module of its own: a recorded run's simulation process opens the file and hands it to its
writer process, and needs neither the MCAP writer nor its imports (mcap, lz4: ~12 ms of its start)."""

from __future__ import annotations

import errno
import fcntl
import functools
import os
import stat
from typing import BinaryIO

from racecar_sim.core.errors import RecordingError


class RecordingFileError(RecordingError, OSError):
    """The recording's file cannot be created: one line naming the path.

    It is a :class:`RecordingError` (so the CLI prints it as one line and exits 2) and
    also an instance of the ``OSError`` subclass ``open()`` raised
    (``FileNotFoundError``, ``PermissionError``, ``IsADirectoryError``...), with its
    ``errno``, ``strerror`` and ``filename``.
    """

    def __str__(self) -> str:
        return f"{self.filename}: cannot create the MCAP file ({self.strerror})"


@functools.cache
def _file_error_type(os_error: type[OSError]) -> type[RecordingFileError]:
    if os_error is OSError or not issubclass(os_error, OSError):
        return RecordingFileError
    return type(f"Recording{os_error.__name__}", (RecordingFileError, os_error), {})


class RecordingInUseError(RecordingError):
    """The recording's file exists and may not be replaced, or another recording is writing it: one line naming it."""


def open_recording_file(path: str | os.PathLike[str], overwrite: bool = True) -> BinaryIO:
    """``path`` open for binary writing, held exclusively: created, or (``overwrite``) an existing file truncated.

    The file is locked (``flock``) for as long as it stays open, in this process or in a writer process it is handed
    to, so that two recordings never write one file: the second is refused. Without ``overwrite`` an existing file
    is refused too (``O_EXCL``: of two runs creating it at once, one gets it). :class:`RecordingInUseError` for
    those; :class:`RecordingFileError` naming the path when it cannot be opened.
    """
    name = os.fspath(path)
    flags = os.O_WRONLY | os.O_CREAT | getattr(os, "O_CLOEXEC", 0) | (0 if overwrite else os.O_EXCL)
    try:
        fd = os.open(name, flags, 0o666)
    except FileExistsError:
        raise RecordingInUseError(
            f"{name}: the file exists and a recording is never replaced unless asked: give "
            "--overwrite to replace it, or another file name"
        ) from None
    except OSError as exc:
        reason = exc.strerror or str(exc)
        # mypy sees no type[X] as Hashable, as functools.cache asks (python/mypy#11470)
        raise _file_error_type(type(exc))(exc.errno, reason, name) from None  # type: ignore[arg-type]
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError as exc:  # another errno: a file system without locks (some network ones), written unguarded
            if exc.errno in (errno.EWOULDBLOCK, errno.EAGAIN):
                raise RecordingInUseError(
                    f"{name}: another recording is writing this file (two would mix into one): give another file name"
                ) from None
        if stat.S_ISREG(os.fstat(fd).st_mode):
            os.ftruncate(fd, 0)
        return os.fdopen(fd, "wb")  # the recorder closes it
    except BaseException:
        os.close(fd)
        raise
