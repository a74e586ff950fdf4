"""ROS 2 ``ackermann_msgs`` messages: AckermannDrive and AckermannDriveStamped."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import ClassVar

from racecar_sim.msgs._base import Message
from racecar_sim.msgs.std_msgs import Header


@dataclass(eq=False, repr=False, slots=True)
class AckermannDrive(Message):
    """Drive command: steering angle (rad), speed (m/s) and their rate limits (0 = unlimited)."""

    __msgtype__: ClassVar[str] = "ackermann_msgs/msg/AckermannDrive"

    steering_angle: float = 0.0
    steering_angle_velocity: float = 0.0
    speed: float = 0.0
    acceleration: float = 0.0
    jerk: float = 0.0


@dataclass(eq=False, repr=False, slots=True)
class AckermannDriveStamped(Message):
    """AckermannDrive with a header."""

    __msgtype__: ClassVar[str] = "ackermann_msgs/msg/AckermannDriveStamped"

    header: Header = field(default_factory=Header)
    drive: AckermannDrive = field(default_factory=AckermannDrive)
