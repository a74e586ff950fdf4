# Written by `python -m racecar_sim.msgs.stubs` from msgs/definitions: do not edit.
from typing import ClassVar

from racecar_sim.msgs._base import Message
from racecar_sim.msgs.typed.builtin_interfaces import Time

class Clock(Message):
    """The ROS message rosgraph_msgs/msg/Clock, made from its definition."""

    __msgtype__: ClassVar[str]
    clock: Time
    def __init__(
        self,
        clock: Time = ...,
    ) -> None: ...
