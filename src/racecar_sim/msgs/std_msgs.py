"""ROS 2 ``std_msgs`` messages: Header, Float64, String, Int8."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import ClassVar

from racecar_sim.msgs._base import Message
from racecar_sim.msgs.builtin_interfaces import Time

_NS_PER_S = 1_000_000_000


@dataclass(eq=False, repr=False, slots=True)
class Header(Message):
    """Timestamp and coordinate frame of the data in a stamped message."""

    __msgtype__: ClassVar[str] = "std_msgs/msg/Header"

    stamp: Time = field(default_factory=Time)
    frame_id: str = ""

    @classmethod
    def at(cls, stamp_ns: int, frame_id: str = "") -> Header:
        """Header stamped at ``stamp_ns`` (integer sim-time nanoseconds) in ``frame_id``."""
        sec, nanosec = divmod(int(stamp_ns), _NS_PER_S)  # Time.from_ns, inline: every stamped message comes here
        return cls(Time(sec, nanosec), frame_id)


@dataclass(eq=False, repr=False, slots=True)
class Float64(Message):
    """A single float64 value."""

    __msgtype__: ClassVar[str] = "std_msgs/msg/Float64"

    data: float = 0.0


@dataclass(eq=False, repr=False, slots=True)
class String(Message):
    """A single string value."""

    __msgtype__: ClassVar[str] = "std_msgs/msg/String"

    data: str = ""


@dataclass(eq=False, repr=False, slots=True)
class Int8(Message):
    """A single int8 value."""

    __msgtype__: ClassVar[str] = "std_msgs/msg/Int8"

    data: int = 0
