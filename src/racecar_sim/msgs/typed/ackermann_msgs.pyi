# Written by `python -m racecar_sim.msgs.stubs` from msgs/definitions: do not edit.
from typing import ClassVar

from racecar_sim.msgs._base import Message
from racecar_sim.msgs.typed.std_msgs import Header

class AckermannDrive(Message):
    """The ROS message ackermann_msgs/msg/AckermannDrive, made from its definition."""

    __msgtype__: ClassVar[str]
    steering_angle: float
    steering_angle_velocity: float
    speed: float
    acceleration: float
    jerk: float
    def __init__(
        self,
        steering_angle: float = ...,
        steering_angle_velocity: float = ...,
        speed: float = ...,
        acceleration: float = ...,
        jerk: float = ...,
    ) -> None: ...

class AckermannDriveStamped(Message):
    """The ROS message ackermann_msgs/msg/AckermannDriveStamped, made from its definition."""

    __msgtype__: ClassVar[str]
    header: Header
    drive: AckermannDrive
    def __init__(
        self,
        header: Header = ...,
        drive: AckermannDrive = ...,
    ) -> None: ...
