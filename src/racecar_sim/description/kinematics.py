"""Forward kinematics over a parsed URDF: what robot_state_publisher computes."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from racecar_sim.core.transforms import compose, quat_from_axis_angle, quat_from_rpy
from racecar_sim.description.urdf import Joint, Robot

Pose = tuple[np.ndarray, np.ndarray]  # position, (w, x, y, z) quaternion


def joint_transform(joint: Joint, position: float = 0.0) -> Pose:
    """Child frame in the parent frame: the joint origin, then the motion about/along the axis."""
    pos = np.array(joint.origin.xyz, dtype=float)
    quat = quat_from_rpy(joint.origin.rpy)
    if joint.type in ("continuous", "revolute"):
        axis = np.array(joint.axis, dtype=float)
        return compose(pos, quat, np.zeros(3), quat_from_axis_angle(axis / np.linalg.norm(axis), position))
    if joint.type == "prismatic":
        axis = np.array(joint.axis, dtype=float)
        return compose(pos, quat, axis / np.linalg.norm(axis) * position, np.array([1.0, 0, 0, 0]))
    return pos, quat


def link_pose(robot: Robot, link: str, positions: Mapping[str, float] | None = None) -> Pose:
    """Pose of `link` in the root link's frame for the given joint positions (default 0)."""
    positions = positions or {}
    pos, quat = np.zeros(3), np.array([1.0, 0, 0, 0])
    chain = []
    joint = robot.joint_to(link)
    while joint is not None:
        chain.append(joint)
        joint = robot.joint_to(joint.parent)
    for joint in reversed(chain):
        pos, quat = compose(pos, quat, *joint_transform(joint, positions.get(joint.name, 0.0)))
    return pos, quat
