"""The end of a `racecar-sim run` process without the interpreter's teardown, where nothing can tell the difference.

Once the command has returned, Python's exit waits for the threads it must wait for, runs the atexit handlers and then
tears the interpreter down: every module's objects freed one by one (numba's, MuJoCo's, the run's), 40-90 ms of CPU
for 1-30 cars on a 2-core machine, none of it work anyone sees. Where that is all the exit would still do, the process
ends right after the atexit handlers (os._exit). It exits as always where something could depend on the teardown: a
thread Python would wait for, a tracer or profiler (they write their output after the command), or code that is
neither racecar-sim's, nor the standard library's, nor an installed package's (a driver file that leaves a file open
relies on the teardown to flush it). Only the command's own entry point (cli.main.entry: the console script and
`python -m racecar_sim`) ends this way; a program that calls cli.main.main() goes on after it.
"""

from __future__ import annotations

import atexit
import os
import sys
import threading


def finish(code: int) -> None:
    """End the process now with exit code `code`, where nothing depends on the interpreter's teardown; otherwise
    return (the caller returns `code`, and Python exits as always)."""
    if not _nothing_depends_on_teardown():
        return
    atexit._run_exitfuncs()  # as Python's exit runs them (it clears them: a normal exit after this runs none again)
    try:
        for stream in (sys.stdout, sys.stderr, sys.__stdout__, sys.__stderr__):
            if stream is not None:
                stream.flush()
    except (OSError, ValueError):  # a pipe closed early, a stream closed: Python's own exit reports it, as always
        return
    _flush_c_streams()
    os._exit(code)


def _flush_c_streams() -> None:
    """What C code (MuJoCo, Mesa, a bridge's library) wrote to its own stdio buffers: exit() flushes them,
    os._exit does not."""
    import ctypes  # already imported by a run (numba, MuJoCo's GL)

    try:
        ctypes.CDLL(None).fflush(None)
    except (AttributeError, OSError, TypeError):  # no C library to load by that name (Windows)
        pass


def _nothing_depends_on_teardown() -> bool:
    return not _waited_for() and _only_known_code()


def _waited_for() -> bool:
    """Whether a tracer or a profiler is on (they write after the command), or a thread runs that Python's exit
    waits for."""
    if sys.gettrace() is not None or sys.getprofile() is not None:
        return True
    main = threading.main_thread()
    return any(t is not main and not t.daemon and t.is_alive() for t in threading.enumerate())


def _only_known_code() -> bool:
    """Whether every module loaded from a file is racecar-sim's or the Python installation's and environment's (the
    standard library, installed packages)."""
    import site

    known = {sys.prefix, sys.base_prefix, sys.exec_prefix, sys.base_exec_prefix, *site.getsitepackages()}
    if site.ENABLE_USER_SITE and site.USER_SITE:
        known.add(site.USER_SITE)
    package = os.path.dirname(os.path.dirname(__file__))  # racecar_sim (an editable install's source tree too)
    known.update((package, os.path.realpath(package)))
    roots = tuple(os.path.join(p, "") for p in known)
    for module in list(sys.modules.values()):
        origin = getattr(getattr(module, "__spec__", None), "origin", None)
        if isinstance(origin, str) and os.sep in origin and not origin.startswith(roots):
            return False
    return True
