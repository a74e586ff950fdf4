"""The methods a few message types carry besides their fields; each is a base of the class made from the definition.

``EXTRAS`` maps the type to its methods' class. The methods read and build the fields their definition gives, so a
definition that changed a field would break them: tests/test_msgs_cdr.py calls each.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, TypeVar

import numpy as np

from racecar_sim.msgs import builtin_interfaces

if TYPE_CHECKING:
    from racecar_sim.msgs.builtin_interfaces import Time

_NS_PER_S = 1_000_000_000
_T = TypeVar("_T", bound="SecondsAndNanoseconds")


class SecondsAndNanoseconds:
    """``builtin_interfaces`` Time and Duration: whole seconds plus nanoseconds in [0, 1e9)."""

    __slots__ = ()
    if TYPE_CHECKING:
        sec: int
        nanosec: int

        def __init__(self, sec: int = 0, nanosec: int = 0) -> None: ...

    @classmethod
    def from_ns(cls: type[_T], ns: int) -> _T:
        """Build from integer nanoseconds (negative times keep nanosec non-negative)."""
        sec, nanosec = divmod(int(ns), _NS_PER_S)
        return cls(sec, nanosec)

    def to_ns(self) -> int:
        """Integer nanoseconds."""
        return self.sec * _NS_PER_S + self.nanosec


_H = TypeVar("_H", bound="HeaderMethods")


class HeaderMethods:
    """``std_msgs/Header``: a header from integer sim-time nanoseconds."""

    __slots__ = ()
    if TYPE_CHECKING:

        def __init__(self, stamp: Time = ..., frame_id: str = "") -> None: ...

    @classmethod
    def at(cls: type[_H], stamp_ns: int, frame_id: str = "") -> _H:
        """Header stamped at ``stamp_ns`` (integer sim-time nanoseconds) in ``frame_id``."""
        sec, nanosec = divmod(int(stamp_ns), _NS_PER_S)  # Time.from_ns, inline: every stamped message comes here
        return cls(builtin_interfaces.Time(sec, nanosec), frame_id)


class ImageMethods:
    """``sensor_msgs/Image``: its pixels as an array."""

    __slots__ = ()
    if TYPE_CHECKING:
        height: int
        width: int
        step: int
        encoding: str
        data: Any

    def bgr_pixels(self) -> np.ndarray:
        """A bgr8 / rgb8 image's pixels as a (height, width, 3) uint8 array in BGR order (a view where it can be)."""
        rows = np.frombuffer(self.data, np.uint8).reshape(self.height, self.step)[:, : self.width * 3]
        pixels = rows.reshape(self.height, self.width, 3)
        return pixels[:, :, ::-1] if self.encoding == "rgb8" else pixels


EXTRAS: dict[str, type] = {
    "builtin_interfaces/msg/Time": SecondsAndNanoseconds,
    "builtin_interfaces/msg/Duration": SecondsAndNanoseconds,
    "std_msgs/msg/Header": HeaderMethods,
    "sensor_msgs/msg/Image": ImageMethods,
}
"""The methods' class of each message type that has some."""
