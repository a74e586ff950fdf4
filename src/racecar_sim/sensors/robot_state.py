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

# a frame's step: (index, parent, child, 3 origin translation, 4 origin rotation w x y z, 3 unit axis) for a moving
# joint, (index, joint) for a prismatic one
_Step = tuple[Any, ...]
_REVOLUTE = 13  # the length of a moving joint's step


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
        self._plan: list[_Step] = []
        self._numbers: Callable[[list[float], int, int], list[Any]] | None = None
        self._layout: CdrLayout | None = None
        bus.subscribe(joint_states_topic, self._on_joint_states, feeds={TF: TFMessage})

    def _make_plan(self, names: list[str]) -> list[_Step]:
        """The frames a joint state of `names` gives, in order: a moving joint's constants (its index in the message,
        parent, child, origin translation, origin rotation w x y z, unit axis), a prismatic joint's index and joint."""
        plan: list[_Step] = []
        for index, name in enumerate(names):
            joint = self._moving.get(name)
            if joint is not None:
                parent, child, pos, quat, axis = joint
                plan.append((index, parent, child, *pos, *quat, *axis))
            elif name in self.sliding:
                plan.append((index, self.sliding[name]))
        self._plan_names, self._plan, self._layout = list(names), plan, None
        self._numbers = _revolute_numbers(plan)
        return plan

    @staticmethod
    def _stepped_numbers(plan: list[_Step], positions: list[float], sec: int, nanosec: int) -> list[Any]:
        """The /tf numbers of `plan`'s frames, step by step: per frame sec, nanosec, translation x y z, rotation x y z
        w (a /tf message's numbers, in wire order)."""
        numbers: list[Any] = []
        for step in plan:
            if len(step) == _REVOLUTE:
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

    def _transforms(self, plan: list[_Step], numbers: list[Any]) -> list[TransformStamped]:
        """The TransformStamped of each of `plan`'s frames, from their numbers (nine each)."""
        transforms = []
        for k, step in enumerate(plan):
            if len(step) == _REVOLUTE:
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


def _revolute_numbers(plan: list[_Step]) -> Callable[[list[float], int, int], list[Any]] | None:
    """One function that gives the /tf numbers of `plan`'s frames, all of moving joints, from the joint positions,
    bit for bit those of RobotStatePublisher._stepped_numbers: each joint's constants written in (repr() reads back to
    the same float), the numbers in one list display, and each rotation component that has one product left once
    the constant zeros' products are dropped computed as that product alone (see _rotation). None where a frame is a
    prismatic joint's (this runs for every joint state, 50 a second a car)."""
    if not plan or any(len(step) != _REVOLUTE for step in plan):
        return None
    lines, items = [], []
    for k, (index, _, _, *constants) in enumerate(plan):
        if not all(math.isfinite(value) for value in constants):
            return None
        lines += [
            f"    h = 0.5 * p[{index}]",
            "    s, c = sin(h), cos(h)",
            *_rotation(k, constants[3:7], constants[7:10]),
        ]
        items += ["sec", "nanosec", *(f"({value!r})" for value in constants[:3]), f"qx{k}, qy{k}, qz{k}, qw{k}"]
    source = "\n".join(["def numbers(p, sec, nanosec):", *lines, f"    return [{', '.join(items)}]"])
    names: dict[str, Any] = {"sin": math.sin, "cos": math.cos}
    exec(compile(source, "<robot_state /tf numbers>", "exec"), names)  # made from the joints' constants alone
    return names["numbers"]


# origin (a) * axis-angle (b): each rotation component x y z w as its four signed products, as quat_mul sums them
_PRODUCTS = (
    (("+", "w", "x"), ("+", "x", "w"), ("+", "y", "z"), ("-", "z", "y")),
    (("+", "w", "y"), ("-", "x", "z"), ("+", "y", "w"), ("+", "z", "x")),
    (("+", "w", "z"), ("+", "x", "y"), ("-", "y", "x"), ("+", "z", "w")),
    (("+", "w", "w"), ("-", "x", "x"), ("-", "y", "y"), ("-", "z", "z")),
)
_SMALLEST = 1e-50  # the least magnitude of a constant a short form multiplies (with |sin| >= 1e-150: no underflow)


def _rotation(k: int, origin: list[float], axis: list[float]) -> list[str]:
    """Lines that set joint k's rotation qx{k} qy{k} qz{k} qw{k} from s = sin(h) and c = cos(h) (h, half its
    angle): the origin rotation `origin` (w x y z) times the axis-angle (c, `axis` * s), summed in quat_mul's order.
    A product with a zero constant (an origin or axis component) is a zero, and adding a zero to a number that is not
    zero gives that number: where one product of a component is left and it cannot be zero (s not zero: then nor is
    any product of constants of at least _SMALLEST, and a cosine never is), the component is that product (negated
    if it is subtracted), the same float. Where s is zero (or NaN), each component is the whole sum (its zero's
    sign, the NaN's bits)."""
    a = dict(zip("wxyz", origin))
    u = {"w": 1.0, **dict(zip("xyz", axis))}
    b = {"w": "c", **{v: f"({u[v]!r} * s)" for v in "xyz"}}  # the axis-angle's components

    def whole(products: tuple[tuple[str, str, str], ...]) -> str:
        terms = [f"{sign} ({a[i]!r}) * {b[j]}" for sign, i, j in products]
        return " ".join(terms)[2:]  # the first product is added: no leading sign

    full = ", ".join(whole(products) for products in _PRODUCTS)
    short = []
    for products in _PRODUCTS:
        left = [(sign, i, j) for sign, i, j in products if a[i] != 0.0 and u[j] != 0.0]
        if len(left) != 1 or abs(a[left[0][1]]) < _SMALLEST or abs(u[left[0][2]]) < _SMALLEST:
            short.append(whole(products))
            continue
        sign, i, j = left[0]
        product = f"({a[i]!r}) * {b[j]}"
        short.append(product if sign == "+" else f"-({product})")
    names = f"qx{k}, qy{k}, qz{k}, qw{k}"
    if short == full.split(", "):
        return [f"    {names} = {full}"]
    return [
        "    if s >= 1e-150 or s <= -1e-150:",
        f"        {names} = {', '.join(short)}",
        "    else:",
        f"        {names} = {full}",
    ]
