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
