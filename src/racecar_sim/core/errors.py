"""Errors with a one-line message naming the file or field at fault."""

from __future__ import annotations


class RacecarSimError(Exception):
    """Base class of every error the simulator raises on bad input."""


class DescriptionError(RacecarSimError):
    """A robot description (xacro, URDF, gazebo tag) is malformed."""


class ConfigError(RacecarSimError, ValueError):
    """A configuration file (controllers, mux, profile, physics preset) or value is malformed.

    Also a ValueError: code that caught the ValueError a bad rate or mode once raised keeps working."""


class WorldError(RacecarSimError):
    """A world file is malformed or names something that does not exist."""


class CommandError(RacecarSimError):
    """A command message carries a NaN, an infinity or an out-of-range value."""


class PhysicsError(RacecarSimError):
    """The physics diverged (NaN or a huge acceleration): the run stops rather than publish NaN."""


class RenderingError(RacecarSimError):
    """No headless OpenGL context (EGL or OSMesa) could be created for the camera."""


class RecordingError(RacecarSimError):
    """An MCAP recording cannot be written, or a file given to recover is missing or not MCAP."""


class NodeError(Exception):
    """A user's node (a driver given to `--driver`, or `sim.add_node`) raised: the run stops at that event.

    Not a RacecarSimError: the input was fine, the node's own code failed. `node` names it (`bad.py:Crashy`), `car`
    its car, `time` the sim time (s) of the event, `where` what the sim was calling (a subscription to /scan, a
    timer, its reset hook); the node's exception is the `__cause__`.
    """

    EXIT_CODE = 3  # racecar-sim's exit code when a user's node stopped the run (docs/errors.md)

    def __init__(self, node: str, car: str, time: float, where: str, cause: BaseException) -> None:
        self.node, self.car, self.time, self.where = node, car, time, where
        super().__init__(
            f"{node} (car {car}) raised {type(cause).__name__}: {one_line(cause)} at sim time {time:.3f} s, in {where}"
        )


def one_line(exc: BaseException) -> str:
    """An exception's message on one line (whitespace runs folded)."""
    return " ".join(str(exc).split()) or "(no message)"
