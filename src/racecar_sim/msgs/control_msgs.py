"""``control_msgs`` messages: JointControllerState, what ros_control's joint controllers publish on `<name>/state`."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import ClassVar

from racecar_sim.msgs._base import Message
from racecar_sim.msgs.std_msgs import Header


@dataclass(eq=False, repr=False, slots=True)
class JointControllerState(Message):
    """State of one joint controller: set point, measured value, error, output effort and PID gains."""

    __msgtype__: ClassVar[str] = "control_msgs/msg/JointControllerState"

    header: Header = field(default_factory=Header)
    set_point: float = 0.0
    process_value: float = 0.0
    process_value_dot: float = 0.0
    error: float = 0.0
    time_step: float = 0.0
    command: float = 0.0
    p: float = 0.0
    i: float = 0.0
    d: float = 0.0
    i_clamp: float = 0.0
    antiwindup: bool = False
