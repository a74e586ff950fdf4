"""What a driver reads from /vesc/odom: the planar pose and the forward speed."""

from __future__ import annotations

import math
from dataclasses import dataclass

from racecar_sim.core.transforms import yaw_of
from racecar_sim.msgs import Odometry


@dataclass(frozen=True)
class PlanarPose:
    """x, y (m), yaw (rad) and forward speed (m/s, negative when reversing) of base_link."""

    x: float
    y: float
    yaw: float
    speed: float


def planar_pose(msg: Odometry) -> PlanarPose:
    """The pose and forward speed of an Odometry message, whichever frame its twist is in.

    REP 105 puts the twist in child_frame_id (base_link); the 2017 sim's gazebo_odometry.py gave it
    in the world frame (child `odom`), so it is projected onto the heading then.
    """
    x, y, yaw = planar_position(msg)
    v = msg.twist.twist.linear
    speed = v.x if msg.child_frame_id == "base_link" else v.x * math.cos(yaw) + v.y * math.sin(yaw)
    return PlanarPose(x, y, yaw, speed)


def planar_position(msg: Odometry) -> tuple[float, float, float]:
    """x, y (m) and yaw (rad) of an Odometry message's pose: planar_pose() without the speed, for a listener of every
    car's odometry that needs no more."""
    pose = msg.pose.pose
    p, q = pose.position, pose.orientation
    return p.x, p.y, yaw_of((q.w, q.x, q.y, q.z))
