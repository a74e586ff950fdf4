# Written by `python -m racecar_sim.msgs.stubs` from msgs/definitions: do not edit.
from typing import ClassVar

from racecar_sim.msgs._base import Message
from racecar_sim.msgs.extras import HeaderMethods
from racecar_sim.msgs.typed.builtin_interfaces import Time

class Float64(Message):
    """The ROS message std_msgs/msg/Float64, made from its definition."""

    __msgtype__: ClassVar[str]
    data: float
    def __init__(
        self,
        data: float = ...,
    ) -> None: ...

class Header(HeaderMethods, Message):
    """The ROS message std_msgs/msg/Header, made from its definition."""

    __msgtype__: ClassVar[str]
    stamp: Time
    frame_id: str
    def __init__(
        self,
        stamp: Time = ...,
        frame_id: str = ...,
    ) -> None: ...

class Int8(Message):
    """The ROS message std_msgs/msg/Int8, made from its definition."""

    __msgtype__: ClassVar[str]
    data: int
    def __init__(
        self,
        data: int = ...,
    ) -> None: ...

class String(Message):
    """The ROS message std_msgs/msg/String, made from its definition."""

    __msgtype__: ClassVar[str]
    data: str
    def __init__(
        self,
        data: str = ...,
    ) -> None: ...
