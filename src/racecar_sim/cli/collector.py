"""The cyclic garbage collector held off while a `racecar-sim` process starts, and what the start made frozen.

Importing a subcommand and building its simulator make a few 10^5 objects (numba's among them) that live as long as
the process. While they are made, the collector would walk them again and again (0.05 s of a camera run's start on a
2-core machine), and at every full collection after, and the interpreter's exit runs one more full collection over
all of them (0.2 s). So the CLI holds the collector off from its start (hold) until the subcommand is ready to run
(release): what exists then is moved out of the collector's way (gc.freeze), and the collector runs as usual for
what the run itself makes. Only for the command's own process: a caller's `main([...])` (a test's) holds nothing,
so that its garbage is never frozen.
"""

from __future__ import annotations

import gc

_held = False


def hold() -> None:
    """Turn the collector off until release()."""
    global _held
    gc.disable()
    _held = True


def release() -> None:
    """Freeze what exists and turn the collector back on, where hold() turned it off (otherwise nothing)."""
    global _held
    if _held:
        _held = False
        gc.freeze()
        gc.enable()


def settle() -> None:
    """At the command's end: release(), and freeze what the run made too, out of the exit's full collection."""
    if _held:
        release()
    gc.freeze()
