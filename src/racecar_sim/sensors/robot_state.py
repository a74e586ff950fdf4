"""robot_state_publisher: fixed joints on /tf_static once (latched), moving joints on /tf per joint state, and the URDF
on /robot_description (latched), as ROS 2's robot_state_publisher gives it to RViz2 and Foxglove."""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import Any

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
from racecar_sim.sensors.tf_rows import REVOLUTE, Step, TfRows, revolute_numbers


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
        # what a joint state of these names (in this order) becomes: one step per frame, what makes its /tf numbers,
        # and the CDR layout of its /tf message once one was recorded (the names, in order, give the frames: bytes
        # for a recorder alone)
        self._plan_names: list[str] | None = None
        self._plan: list[Step] = []
        self._numbers: Callable[[Sequence[float], int, int], list[Any]] | None = None
        self._layout: CdrLayout | None = None
        self._rows: TfRows | None = None  # what packs the plan's /tf messages from joint-state rows (joint_state_rows)

        def on_joint_states(msg: JointState) -> None:
            self._on_joint_states(msg)

        # what a joint-state publisher whose messages only a recorder and this take (Bus.sole_feeder) may ask for
        on_joint_states.joint_state_rows = self.joint_state_rows  # type: ignore[attr-defined]
        bus.subscribe(joint_states_topic, on_joint_states, feeds={TF: TFMessage})

    def joint_state_rows(self, names: list[str]) -> tuple[type, TfRows, tuple[str, ...]] | None:
        """What /tf is made of joint states of `names` handed over as rows (sec, nanosec, positions, velocities,
        efforts) where only a recorder takes /tf: its message class, what packs each row's /tf message (the numbers
        _on_joint_states gives, packed by the layout it would read), its topics. None where a frame is not a moving
        joint's or the frames' message has no layout."""
        if names != self._plan_names:
            self._make_plan(list(names))
        plan, numbers = self._plan, self._numbers
        if numbers is None:
            return None
        if self._rows is None or self._rows.plan != tuple(plan):
            layout = self._layout or CdrLayout.read(
                TFMessage(self._transforms(plan, numbers([0.0] * len(names), 0, 0)))
            )
            if layout is None:
                return None
            self._layout, self._rows = layout, TfRows(layout, plan)
        return TFMessage, self._rows, (TF,)

    def _make_plan(self, names: list[str]) -> list[Step]:
        """The frames a joint state of `names` gives, in order: a moving joint's constants (its index in the message,
        parent, child, origin translation, origin rotation w x y z, unit axis), a prismatic joint's index and joint."""
        plan: list[Step] = []
        for index, name in enumerate(names):
            joint = self._moving.get(name)
            if joint is not None:
                parent, child, pos, quat, axis = joint
                plan.append((index, parent, child, *pos, *quat, *axis))
            elif name in self.sliding:
                plan.append((index, self.sliding[name]))
        self._plan_names, self._plan, self._layout, self._rows = list(names), plan, None, None
        self._numbers = revolute_numbers(plan)
        return plan

    @staticmethod
    def _stepped_numbers(plan: list[Step], positions: list[float], sec: int, nanosec: int) -> list[Any]:
        """The /tf numbers of `plan`'s frames, step by step: per frame sec, nanosec, translation x y z, rotation x y z
        w (a /tf message's numbers, in wire order)."""
        numbers: list[Any] = []
        for step in plan:
            if len(step) == REVOLUTE:
                # origin * axis-angle, in plain floats: the same IEEE operations quat_mul(quat_from_axis_angle)
                # does on numpy scalars
                index, _, _, px, py, pz, aw, ax, ay, az, ux, uy, uz = step
                half = 0.5 * positions[index]
                s = math.sin(half)
                bw, bx, by, bz = math.cos(half), ux * s, uy * s, uz * s
                numbers += (
                    sec,
                    nanosec,
                    px,
                    py,
                    pz,
                    aw * bx + ax * bw + ay * bz - az * by,
                    aw * by - ax * bz + ay * bw + az * bx,
                    aw * bz + ax * by - ay * bx + az * bw,
                    aw * bw - ax * bx - ay * by - az * bz,
                )
            else:
                (tx, ty, tz), (w, x, y, z) = joint_transform(step[1], positions[step[0]])
                numbers += (sec, nanosec, float(tx), float(ty), float(tz), float(x), float(y), float(z), float(w))
        return numbers

    def _on_joint_states(self, msg: JointState) -> None:
        bus = self.bus
        if not bus.has_listeners(TF):  # as a ROS publisher with no subscriber, nothing goes out: no need to build
            bus.tally(TF, TFMessage)
            return
        sec, nanosec = divmod(msg.header.stamp.to_ns(), NS_PER_S)
        plan = self._plan
        if msg.name != self._plan_names and list(msg.name) != self._plan_names:
            plan = self._make_plan(list(msg.name))
        positions = _floats(msg.position)
        if len(positions) < len(msg.name):  # the named joints that have a position alone (not this plan's frames)
            plan = [step for step in plan if step[0] < len(positions)]
            tf = TFMessage(self._transforms(plan, self._stepped_numbers(plan, positions, sec, nanosec)))
            bus.publish(TF, tf)
            return
        if self._numbers is not None:
            numbers = self._numbers(positions, sec, nanosec)
        else:
            numbers = self._stepped_numbers(plan, positions, sec, nanosec)
        cdr = bus.cdr_only(TF)  # only a recorder takes /tf: its bytes, packed from the numbers
        if cdr and self._layout is not None:
            bus.publish_cdr(TF, TFMessage, self._layout.pack(numbers))
            return
        tf = TFMessage(self._transforms(plan, numbers))
        if cdr:  # the layout of these frames, for the next joint states of the same names
            self._layout = CdrLayout.read(tf)
        bus.publish(TF, tf)

    def _transforms(self, plan: list[Step], numbers: list[Any]) -> list[TransformStamped]:
        """The TransformStamped of each of `plan`'s frames, from their numbers (nine each)."""
        transforms = []
        for k, step in enumerate(plan):
            if len(step) == REVOLUTE:
                parent, child = step[1], step[2]
            else:
                slider = step[1]
                parent, child = self.frame(slider.parent), self.frame(slider.child)
            sec, nanosec, px, py, pz, qx, qy, qz, qw = numbers[9 * k : 9 * k + 9]
            transforms.append(
                TransformStamped(
                    Header(Time(sec, nanosec), parent),
                    child,
                    Transform(Vector3(px, py, pz), Quaternion(qx, qy, qz, qw)),
                )
            )
        return transforms


def _floats(values: np.ndarray | Sequence[float]) -> list[float]:
    """Joint positions as Python floats (a message's numpy array, or a list from elsewhere)."""
    return values.tolist() if isinstance(values, np.ndarray) else [float(v) for v in values]
