"""robot_state_publisher: fixed joints on /tf_static once (latched), moving joints on /tf per joint state, and the URDF
on /robot_description (latched), as ROS 2's robot_state_publisher gives it to RViz2 and Foxglove."""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from racecar_sim.bus import BusPort
from racecar_sim.core.names import ROBOT_DESCRIPTION, TF, TF_STATIC, CarNames
from racecar_sim.core.time import NS_PER_S
from racecar_sim.core.transforms import quat_from_rpy
from racecar_sim.description.kinematics import joint_transform
from racecar_sim.description.urdf import Robot
from racecar_sim.msgs import (
    Header,
    JointState,
    Quaternion,
    String,
    TFMessage,
    Time,
    Transform,
    TransformStamped,
    Vector3,
)
from racecar_sim.msgs.cdr_layout import CdrLayout
from racecar_sim.nodes import NodeBase, StaticTf


def transform_msg(stamp_ns: int, parent: str, child: str, pos: np.ndarray, quat_wxyz: np.ndarray) -> TransformStamped:
    """A TransformStamped (ROS quaternion order x, y, z, w)."""
    w, x, y, z = (float(v) for v in quat_wxyz)
    return TransformStamped(
        Header.at(stamp_ns, parent), child, Transform(Vector3(*(float(v) for v in pos)), Quaternion(x, y, z, w))
    )


class StaticTransforms:
    """/tf_static for every car: one latched message holding all static transforms so far, as a tf2
    StaticTransformBroadcaster sends (a latched topic keeps one message, so cars must not overwrite each other)."""

    def __init__(self, bus: BusPort) -> None:
        self.bus = bus
        self.transforms: list[TransformStamped] = []
        bus.latch(TF_STATIC)

    def add(self, transforms: list[TransformStamped]) -> None:
        self.transforms.extend(transforms)
        self.bus.publish(TF_STATIC, TFMessage(list(self.transforms)))


class RobotStatePublisher(NodeBase):
    """Publishes the URDF tree as TF (frames with the car's tf_prefix), from the joint states on
    `joint_states_topic`, and the URDF itself on the car's /robot_description (latched: `/car2/robot_description` in a
    fleet; the text is the description's, frames without the prefix, as robot_state_publisher's frame_prefix leaves
    it)."""

    def __init__(
        self,
        bus: BusPort,
        robot: Robot,
        joint_states_topic: str = "/racecar/joint_states",
        names: CarNames = CarNames(),
        static: StaticTf | None = None,
    ) -> None:
        self.bus = bus
        frame = names.frame
        # Revolute/continuous joints turn about the child origin: the translation is the joint origin's,
        # the rotation is origin * axis-angle. Precomputed here, because /tf goes out at 50 Hz.
        self.moving = {
            j.name: (
                frame(j.parent),
                frame(j.child),
                np.array(j.origin.xyz),
                quat_from_rpy(j.origin.rpy),
                np.array(j.axis) / np.linalg.norm(j.axis),
            )
            for j in robot.joints.values()
            if j.type in ("revolute", "continuous")
        }
        self.sliding = {j.name: j for j in robot.joints.values() if j.type == "prismatic"}
        self._moving = {
            name: (parent, child, tuple(pos.tolist()), tuple(quat.tolist()), tuple(axis.tolist()))
            for name, (parent, child, pos, quat, axis) in self.moving.items()
        }
        self.frame = frame
        fixed = [
            transform_msg(0, frame(j.parent), frame(j.child), *joint_transform(j))
            for j in robot.joints.values()
            if not j.moves
        ]
        (static or StaticTransforms(bus)).add(fixed)
        if robot.urdf:
            description = names.topic(ROBOT_DESCRIPTION)
            bus.latch(description)
            bus.publish(description, String(robot.urdf))
        # the CDR layout of a /tf message, with the joint names of the joint state it was made of and its number of
        # frames (the names, in order, give the frames: bytes for a recorder alone)
        self._layout: tuple[list[str], int, CdrLayout] | None = None
        bus.subscribe(joint_states_topic, self._on_joint_states, feeds={TF: TFMessage})

    def _on_joint_states(self, msg: JointState) -> None:
        bus = self.bus
        if not bus.has_listeners(TF):  # as a ROS publisher with no subscriber, nothing goes out: no need to build
            bus.tally(TF, TFMessage)
            return
        stamp_ns = msg.header.stamp.to_ns()
        sec, nanosec = divmod(stamp_ns, NS_PER_S)
        frames = []  # parent, child, translation x y z, rotation x y z w: one transform each
        moving = self._moving
        for name, position in zip(msg.name, _floats(msg.position)):
            joint = moving.get(name)
            if joint is not None:
                # origin * axis-angle, in plain floats: the same IEEE operations quat_mul(quat_from_axis_angle)
                # does on numpy scalars, at a fraction of the cost (this runs for every joint at 50 Hz)
                parent, child, (px, py, pz), (aw, ax, ay, az), (ux, uy, uz) = joint
                half = 0.5 * position
                s = math.sin(half)
                bw, bx, by, bz = math.cos(half), ux * s, uy * s, uz * s
                frames.append(
                    (
                        parent,
                        child,
                        px,
                        py,
                        pz,
                        aw * bx + ax * bw + ay * bz - az * by,
                        aw * by - ax * bz + ay * bw + az * bx,
                        aw * bz + ax * by - ay * bx + az * bw,
                        aw * bw - ax * bx - ay * by - az * bz,
                    )
                )
            elif name in self.sliding:
                slider = self.sliding[name]
                (px, py, pz), (w, x, y, z) = joint_transform(slider, float(position))
                frames.append(
                    (
                        self.frame(slider.parent),
                        self.frame(slider.child),
                        float(px),
                        float(py),
                        float(pz),
                        float(x),
                        float(y),
                        float(z),
                        float(w),
                    )
                )
        cdr = bus.cdr_only(TF)  # only a recorder takes /tf: its bytes, packed from the numbers
        if cdr and self._layout is not None:
            names, count, layout = self._layout
            if len(frames) == count and names == list(msg.name):  # the same joints in the same order: the same frames
                numbers = [value for frame in frames for value in (sec, nanosec, *frame[2:])]
                bus.publish_cdr(TF, TFMessage, layout.pack(numbers))
                return
        tf = TFMessage(
            [
                TransformStamped(
                    Header(Time(sec, nanosec), parent),
                    child,
                    Transform(Vector3(px, py, pz), Quaternion(qx, qy, qz, qw)),
                )
                for parent, child, px, py, pz, qx, qy, qz, qw in frames
            ]
        )
        if cdr:  # the layout of this message's frames, for the next ones
            read = CdrLayout.read(tf)
            self._layout = None if read is None else (list(msg.name), len(frames), read)
        bus.publish(TF, tf)


def _floats(values: np.ndarray | Sequence[float]) -> list[float]:
    """Joint positions as Python floats (a message's numpy array, or a list from elsewhere)."""
    return values.tolist() if isinstance(values, np.ndarray) else [float(v) for v in values]
