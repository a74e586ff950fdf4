# Written by `python -m racecar_sim.msgs.stubs` from msgs/definitions: do not edit.
from typing import ClassVar

from racecar_sim.msgs._base import Message
from racecar_sim.msgs.extras import SecondsAndNanoseconds

class Duration(SecondsAndNanoseconds, Message):
    """The ROS message builtin_interfaces/msg/Duration, made from its definition."""

    __msgtype__: ClassVar[str]
    sec: int
    nanosec: int
    def __init__(
        self,
        sec: int = ...,
        nanosec: int = ...,
    ) -> None: ...

class Time(SecondsAndNanoseconds, Message):
    """The ROS message builtin_interfaces/msg/Time, made from its definition."""

    __msgtype__: ClassVar[str]
    sec: int
    nanosec: int
    def __init__(
        self,
        sec: int = ...,
        nanosec: int = ...,
    ) -> None: ...
