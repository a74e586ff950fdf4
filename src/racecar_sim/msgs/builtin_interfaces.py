"""ROS 2 ``builtin_interfaces`` messages: Time and Duration."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

from racecar_sim.msgs._base import Message

_NS_PER_S = 1_000_000_000


@dataclass(eq=False, repr=False, slots=True)
class Time(Message):
    """A point in time: whole seconds plus nanoseconds in [0, 1e9)."""

    __msgtype__: ClassVar[str] = "builtin_interfaces/msg/Time"

    sec: int = 0
    nanosec: int = 0

    @classmethod
    def from_ns(cls, ns: int) -> Time:
        """Build from integer nanoseconds (negative times keep nanosec non-negative)."""
        sec, nanosec = divmod(int(ns), _NS_PER_S)
        return cls(sec, nanosec)

    def to_ns(self) -> int:
        """Integer nanoseconds."""
        return self.sec * _NS_PER_S + self.nanosec


@dataclass(eq=False, repr=False, slots=True)
class Duration(Message):
    """A span of time: whole seconds plus nanoseconds in [0, 1e9)."""

    __msgtype__: ClassVar[str] = "builtin_interfaces/msg/Duration"

    sec: int = 0
    nanosec: int = 0

    @classmethod
    def from_ns(cls, ns: int) -> Duration:
        """Build from integer nanoseconds."""
        sec, nanosec = divmod(int(ns), _NS_PER_S)
        return cls(sec, nanosec)

    def to_ns(self) -> int:
        """Integer nanoseconds."""
        return self.sec * _NS_PER_S + self.nanosec
