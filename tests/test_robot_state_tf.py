"""robot_state_publisher's /tf from joint states: bit for bit the kinematics' transforms (description.kinematics'
joint_transform, numpy's quaternion product), whether a recorder takes the bytes or a subscriber the message."""

from __future__ import annotations

import math
import pickle
import random
import struct

import numpy as np
import pytest

from racecar_sim.bus import Bus
from racecar_sim.core.names import TF
from racecar_sim.description import load_robot
from racecar_sim.description.kinematics import joint_transform
from racecar_sim.description.urdf import Robot, parse_urdf
from racecar_sim.msgs import Header, JointState, TFMessage
from racecar_sim.msgs.cdr import serialize
from racecar_sim.sensors.robot_state import RobotStatePublisher, transform_msg
from racecar_sim.sensors.tf_rows import revolute_numbers

# zeros of both signs, angles whose sine is tiny or subnormal, and ordinary ones
SPECIAL = [0.0, -0.0, 1e-160, -1e-160, 3e-300, -5e-324, 1e-320, math.pi, -math.pi, 2 * math.pi, 1e6, 0.3, -2.5]


def _arbitrary_robot(seed: int) -> Robot:
    """Revolute joints with random origins and axes (some axis components zero, some tiny)."""
    rng = random.Random(seed)
    joints, links = [], ['<link name="base"/>']
    for k in range(5):
        rpy = " ".join(str(rng.choice([0.0, rng.uniform(-3, 3), math.pi / 2])) for _ in range(3))
        axis = " ".join(str(rng.choice([0.0, 1.0, -1.0, rng.uniform(-1, 1), 1e-12])) for _ in range(3))
        axis = "0 0 1" if all(float(v) == 0.0 for v in axis.split()) else axis
        links.append(f'<link name="l{k}"/>')
        joints.append(
            f'<joint name="j{k}" type="{rng.choice(["revolute", "continuous"])}"><parent link="base"/>'
            f'<child link="l{k}"/><origin xyz="0.1 {k} -0.2" rpy="{rpy}"/><axis xyz="{axis}"/>'
            '<limit lower="-10" upper="10" effort="1" velocity="1"/></joint>'
        )
    return parse_urdf(f'<robot name="r">{"".join(links + joints)}</robot>')


def _expected(robot: Robot, stamp_ns: int, positions: dict[str, float]) -> bytes:
    joints = [robot.joints[name] for name in positions]
    return serialize(
        TFMessage([transform_msg(stamp_ns, j.parent, j.child, *joint_transform(j, positions[j.name])) for j in joints])
    )


def _joint_states(robot: Robot, rng: random.Random, count: int) -> list[dict[str, float]]:
    names = [j.name for j in robot.joints.values() if j.type in ("revolute", "continuous")]
    states = [dict.fromkeys(names, value) for value in SPECIAL]
    states += [{name: rng.choice([rng.uniform(-7, 7), *SPECIAL]) for name in names} for _ in range(count)]
    return states


@pytest.mark.parametrize("robot", [load_robot(), _arbitrary_robot(1), _arbitrary_robot(2)], ids=["racecar", "a", "b"])
@pytest.mark.parametrize("taker", ["recorder", "subscriber"])
def test_tf_is_the_kinematics_bit_for_bit(robot: Robot, taker: str) -> None:
    bus = Bus()
    got: list[bytes] = []
    if taker == "recorder":  # a CDR tap alone: the bytes are packed from the numbers
        bus.tap(
            lambda topic, msg: got.append(serialize(msg)) if topic == TF else None,
            cdr=lambda topic, cls, data: got.append(data) if topic == TF else None,
        )
    else:
        bus.subscribe(TF, lambda msg: got.append(serialize(msg)))
    RobotStatePublisher(bus, robot, "/joint_states")
    states = _joint_states(robot, random.Random(7), 200)
    for k, positions in enumerate(states):
        stamp_ns = 1_000_000_007 * k
        names = list(positions)
        bus.publish(
            "/joint_states",
            JointState(
                Header.at(stamp_ns),
                names,
                np.array(list(positions.values())),
                np.zeros(len(names)),
                np.zeros(len(names)),
            ),
        )
    assert len(got) == len(states)
    for k, (data, positions) in enumerate(zip(got, states)):
        assert data == _expected(robot, 1_000_000_007 * k, positions), positions


@pytest.mark.parametrize("robot", [load_robot(), _arbitrary_robot(1), _arbitrary_robot(2)], ids=["racecar", "a", "b"])
def test_a_writers_tf_rows_pack_the_kinematics_bit_for_bit(robot: Robot) -> None:
    """/tf made in a writer process from joint-state rows (sec, nanosec, positions, velocities, efforts), by its copy
    of what robot_state_publisher hands over (joint_state_rows): the kinematics' bytes, as the in-process ways."""
    bus = Bus()
    publisher = RobotStatePublisher(bus, robot, "/joint_states")
    states = _joint_states(robot, random.Random(7), 200)
    names = list(states[0])
    fed = publisher.joint_state_rows(names)
    assert fed is not None
    cls, packer, topics = fed
    assert cls is TFMessage and topics == (TF,)
    writers = pickle.loads(pickle.dumps(packer))  # as a writer process unpickles it: its numbers made again
    velocities = [1.5 * k for k in range(len(names))]
    for k, positions in enumerate(states):
        stamp_ns = 1_000_000_007 * k
        row = (*divmod(stamp_ns, 1_000_000_000), *positions.values(), *velocities, *velocities)
        (data,) = writers.pack_many(pickle.loads(pickle.dumps([row], 5)))
        assert data == _expected(robot, stamp_ns, positions), positions
    prismatic = parse_urdf(
        '<robot name="p"><link name="a"/><link name="b"/><joint name="s" type="prismatic"><parent link="a"/>'
        '<child link="b"/><axis xyz="1 0 0"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint></robot>'
    )
    assert RobotStatePublisher(Bus(), prismatic, "/joint_states").joint_state_rows(["s"]) is None  # objects, then


def test_a_nan_position_gives_the_bits_of_the_step_by_step_sum() -> None:
    """A NaN (a diverged simulation) takes the whole sums, as the step-by-step code does: the same NaN bits."""
    robot = RobotStatePublisher(Bus(), load_robot(), "/joint_states")
    names = list(robot._moving)
    plan = robot._make_plan(names)
    numbers = revolute_numbers(plan)
    assert numbers is not None
    for positions in ([math.nan] * len(names), [-math.nan] * len(names), [0.5, math.nan, -0.0, 0.0, math.nan, 2.0]):
        got = numbers(positions, 3, 4)
        want = RobotStatePublisher._stepped_numbers(plan, positions, 3, 4)
        assert [struct.pack("<d", v) for v in got] == [struct.pack("<d", v) for v in want]
