"""ROS 2 ``rosgraph_msgs`` messages: Clock."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import ClassVar

from racecar_sim.msgs._base import Message
from racecar_sim.msgs.builtin_interfaces import Time


@dataclass(eq=False, repr=False, slots=True)
class Clock(Message):
    """The current simulation time, as published on ``/clock``."""

    __msgtype__: ClassVar[str] = "rosgraph_msgs/msg/Clock"

    clock: Time = field(default_factory=Time)
