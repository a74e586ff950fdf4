# Written by `python -m racecar_sim.msgs.stubs` from msgs/definitions: do not edit.
from typing import ClassVar

from racecar_sim.msgs._base import Message
from racecar_sim.msgs.typed.std_msgs import Header

class JointControllerState(Message):
    """control_msgs/JointControllerState (ROS 1 noetic; the same fields in ROS 2): the state of one joint
    controller."""

    __msgtype__: ClassVar[str]
    header: Header
    set_point: float
    process_value: float
    process_value_dot: float
    error: float
    time_step: float
    command: float
    p: float
    i: float
    d: float
    i_clamp: float
    antiwindup: bool
    def __init__(
        self,
        header: Header = ...,
        set_point: float = ...,
        process_value: float = ...,
        process_value_dot: float = ...,
        error: float = ...,
        time_step: float = ...,
        command: float = ...,
        p: float = ...,
        i: float = ...,
        d: float = ...,
        i_clamp: float = ...,
        antiwindup: bool = ...,
    ) -> None: ...
