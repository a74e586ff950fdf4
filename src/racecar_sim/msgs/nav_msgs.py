"""ROS 2 ``nav_msgs`` messages: Odometry."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import ClassVar

from racecar_sim.msgs._base import Message
from racecar_sim.msgs.geometry_msgs import PoseWithCovariance, TwistWithCovariance
from racecar_sim.msgs.std_msgs import Header


@dataclass(eq=False, repr=False, slots=True)
class Odometry(Message):
    """Pose in ``header.frame_id`` and twist in ``child_frame_id``, with covariances."""

    __msgtype__: ClassVar[str] = "nav_msgs/msg/Odometry"

    header: Header = field(default_factory=Header)
    child_frame_id: str = ""
    pose: PoseWithCovariance = field(default_factory=PoseWithCovariance)
    twist: TwistWithCovariance = field(default_factory=TwistWithCovariance)
