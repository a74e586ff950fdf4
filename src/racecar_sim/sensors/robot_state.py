"""robot_state_publisher: fixed joints on /tf_static once (latched), moving joints on /tf per joint state."""

from __future__ import annotations

import numpy as np

from racecar_sim.bus import Bus
from racecar_sim.core.transforms import quat_from_axis_angle, quat_from_rpy, quat_mul
from racecar_sim.description.kinematics import joint_transform
from racecar_sim.description.urdf import Robot
from racecar_sim.msgs import Header, JointState, Quaternion, TFMessage, Transform, TransformStamped, Vector3


def transform_msg(stamp_ns: int, parent: str, child: str, pos: np.ndarray, quat_wxyz: np.ndarray) -> TransformStamped:
    """A TransformStamped (ROS quaternion order x, y, z, w)."""
    w, x, y, z = (float(v) for v in quat_wxyz)
    return TransformStamped(Header.at(stamp_ns, parent), child,
                            Transform(Vector3(*(float(v) for v in pos)), Quaternion(x, y, z, w)))


class RobotStatePublisher:
    """Publishes the URDF tree as TF, from the joint states on `joint_states_topic`."""

    def __init__(self, bus: Bus, robot: Robot, joint_states_topic: str = "/racecar/joint_states") -> None:
        self.bus = bus
        # Revolute/continuous joints turn about the child origin: the translation is the joint origin's,
        # the rotation is origin * axis-angle. Precomputed here, because /tf goes out at 50 Hz.
        self.moving = {j.name: (j.parent, j.child, np.array(j.origin.xyz), quat_from_rpy(j.origin.rpy),
                                np.array(j.axis) / np.linalg.norm(j.axis))
                       for j in robot.joints.values() if j.type in ("revolute", "continuous")}
        self.sliding = {j.name: j for j in robot.joints.values() if j.type == "prismatic"}
        bus.latch("/tf_static")
        fixed = [transform_msg(0, j.parent, j.child, *joint_transform(j)) for j in robot.joints.values() if not j.moves]
        bus.publish("/tf_static", TFMessage(fixed))
        bus.subscribe(joint_states_topic, self._on_joint_states)

    def _on_joint_states(self, msg: JointState) -> None:
        stamp = msg.header.stamp.to_ns()
        transforms = []
        for name, position in zip(msg.name, msg.position):
            if name in self.moving:
                parent, child, pos, quat, axis = self.moving[name]
                rotation = quat_mul(quat, quat_from_axis_angle(axis, float(position)))
                transforms.append(transform_msg(stamp, parent, child, pos, rotation))
            elif name in self.sliding:
                joint = self.sliding[name]
                transforms.append(transform_msg(stamp, joint.parent, joint.child, *joint_transform(joint, float(position))))
        self.bus.publish("/tf", TFMessage(transforms))
