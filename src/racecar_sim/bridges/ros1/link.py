"""The sim's end of the pipe to ros_side.py: the frames every bridge uses (bridges/link.py).

Frames are those of ros_side.py: uint32 length (little-endian) of what follows, one byte of kind, the payload;
CONTROL payloads are pickled dicts, DATA payloads a uint32 id and ROS 1 message bytes.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence

from racecar_sim.bridges.link import CONTROL, DATA, ID, SideLink

__all__ = ["CONTROL", "DATA", "ID", "RosSideLink"]


class RosSideLink(SideLink):
    """The ROS 1 side process and its pipe. `on_frame(kind, payload)` runs on the reader thread."""

    def __init__(self, command: Sequence[str], env: Mapping[str, str], on_frame: Callable[[int, bytes], None]) -> None:
        super().__init__(command, env, on_frame, name="ros1-bridge-reader")
