"""CdrLayout: a message's bytes packed from its numbers are serialize()'s bytes of the message with those numbers
(serialize itself is checked against rosbags in test_msgs_cdr.py), for every kind of field a state topic has."""

from __future__ import annotations

import pickle

import numpy as np
import pytest

from racecar_sim import msgs
from racecar_sim.msgs.cdr_layout import CdrLayout, FilledLayout


def _pose(k: float) -> msgs.Pose:
    return msgs.Pose(msgs.Point(k, -k, 0.5), msgs.Quaternion(0.0, 0.0, np.sin(k), np.cos(k)))


def _twist(k: float) -> msgs.Twist:
    return msgs.Twist(msgs.Vector3(k, 2 * k, -k), msgs.Vector3(0.1, 0.0, k / 3))


def _link_states(k: float) -> msgs.LinkStates:
    names = ["ground_plane::link", "car1::base_link", "car1::left_front_wheel"]
    return msgs.LinkStates(names, [_pose(k + i) for i in range(3)], [_twist(k - i) for i in range(3)])


def _state(k: float) -> msgs.JointControllerState:
    return msgs.JointControllerState(msgs.Header.at(int(k * 1e9)), k, -k, 0.0, 2 * k, 0.001, k / 7, 1.0, 0.5, 0.0,
                                     10.0, k > 1)  # fmt: skip


def _tf(k: float) -> msgs.TFMessage:
    return msgs.TFMessage(
        [
            msgs.TransformStamped(
                msgs.Header.at(int(k * 1e9), parent),
                child,
                msgs.Transform(msgs.Vector3(k, 0, 1), msgs.Quaternion(0, 0, np.sin(k), np.cos(k))),
            )  # fmt: skip
            for parent, child in (("car1/base_link", "car1/left_front_wheel"), ("odom", "car1/base_footprint"))
        ]
    )


def _odometry(k: float) -> msgs.Odometry:
    cov = np.arange(36.0) * k
    return msgs.Odometry(msgs.Header.at(int(k * 1e9), "odom"), "base_link", msgs.PoseWithCovariance(_pose(k), cov),
                         msgs.TwistWithCovariance(_twist(k), -cov))  # fmt: skip


def _scan(k: float) -> msgs.LaserScan:
    ranges = (np.linspace(0.1, 10, 7) * k).astype(np.float32)
    return msgs.LaserScan(msgs.Header.at(int(k * 1e9), "laser"), -2.3, 2.3, 0.004, 0.0, 0.025, 0.1, 10.0, ranges,
                          np.zeros(0, np.float32))  # fmt: skip


def _joint_state(k: float) -> msgs.JointState:
    return msgs.JointState(msgs.Header.at(int(k * 1e9)), ["a", "bb", "ccc"], np.array([k, 2 * k, 3.0]),
                           np.array([1.0, -k, 0.0]), np.zeros(0))  # fmt: skip


MAKERS = [_link_states, _state, _tf, _odometry, _scan, _joint_state, lambda k: msgs.Clock(msgs.Time(int(k), 17))]


@pytest.mark.parametrize("make", MAKERS)
def test_packed_numbers_are_serialize_bytes(make) -> None:
    layout, numbers = CdrLayout.of(make(1.25))
    assert layout.count == len(numbers)
    other = make(2.5)  # the same shape, other numbers (and another bool)
    again = CdrLayout.of(other)
    assert again is not None
    assert layout.pack(again[1]) == msgs.serialize(other)
    assert numbers != again[1]
    assert layout.pack_many([again[1], numbers]) == [msgs.serialize(other), msgs.serialize(make(1.25))]


def test_pack_doubles_gives_pack_bytes_for_float64_layouts() -> None:
    layout, _ = CdrLayout.of(_link_states(0.3))
    _, numbers = CdrLayout.of(_link_states(4.0))
    assert layout.pack_doubles(np.array(numbers)) == msgs.serialize(_link_states(4.0))
    state, state_numbers = CdrLayout.of(_state(1.5))  # not all float64: pack_doubles packs it as pack does
    assert state.pack_doubles(np.array(state_numbers, dtype=object)) == msgs.serialize(_state(1.5))


def test_no_layout_for_byte_arrays() -> None:
    image = msgs.Image(msgs.Header.at(0, "camera"), 2, 2, "rgb8", 0, 6, np.zeros(12, np.uint8))
    assert CdrLayout.of(image) is None


@pytest.mark.parametrize("make", MAKERS)
def test_a_pickled_layout_packs_the_same_bytes(make) -> None:
    """A writer process packs rows with the layout it was handed (pickled as what makes it): the same bytes."""
    layout, numbers = CdrLayout.of(make(1.25))
    _, other = CdrLayout.of(make(2.5))
    copy = pickle.loads(pickle.dumps(layout))
    assert copy is not layout and copy.msgtype == layout.msgtype
    assert copy.pack_many([numbers, other]) == [msgs.serialize(make(1.25)), msgs.serialize(make(2.5))]


def test_a_filled_layout_packs_the_template_with_the_arrays_in_place() -> None:
    """FilledLayout (the state topics a writer packs from link_arrays()' bytes): the template's numbers with the rows'
    arrays put where `fills` says, packed as pack() packs them, also after a pickle (a writer process's copy)."""
    layout, template = CdrLayout.of(_link_states(0.3))
    _, wanted = CdrLayout.of(_link_states(4.0))
    poses = np.array([wanted[7:14], wanted[14:21]])  # the second and third links' poses (7 numbers each)
    twists = np.array([wanted[21 + 6 : 21 + 12], wanted[21 + 12 : 21 + 18]])
    fills = [(np.arange(7, 21), 0, np.arange(14)), (np.arange(27, 39), 1, np.arange(12))]
    filled = FilledLayout(layout, np.array(template), fills)
    expected = layout.pack([*template[:7], *wanted[7:21], *template[21:27], *wanted[27:39]])
    row = (poses.tobytes(), twists.tobytes())
    assert filled.pack_many([row, row]) == [expected, expected]
    assert pickle.loads(pickle.dumps(filled)).pack_many([row]) == [expected]
    assert expected != layout.pack(template) and expected != msgs.serialize(_link_states(4.0))  # mixed: both change


def test_a_filled_layout_packs_what_filling_the_numbers_one_by_one_packs() -> None:
    """pack_many() writes the filled numbers into the template's bytes; the same bytes as filling the template's numbers
    fill by fill and packing them (FilledLayout._packed, the way it packed before), for the real shape of a recorded
    tick: links' poses and twists from two arrays, a number filled twice (the last fill wins), a row whose arrays
    change length (a new recipe)."""
    layout, template = CdrLayout.of(_link_states(0.3))
    rng = np.random.default_rng(7)
    poses, twists = rng.normal(size=(2, 7)), rng.normal(size=(2, 6))
    poses[1, 2] = -0.0  # a negative zero and a NaN keep their bits
    twists[0, 4] = np.nan
    fills = [
        (np.arange(7, 21), 0, np.arange(14)),
        (np.arange(27, 39), 1, np.arange(12)),
        (np.array([0, 7]), 1, np.array([5, 11])),  # the first link's x and the second's x again, from the twists
    ]
    filled = FilledLayout(layout, np.array(template), fills)
    rows = [(poses.tobytes(), twists.tobytes()), ((poses * 3).tobytes(), twists[::-1].copy().tobytes())]
    expected = [filled._packed([np.frombuffer(a, "<f8") for a in row]) for row in rows]
    assert filled.pack_many(rows) == expected
    numbers = np.array(template)
    numbers[7:21], numbers[27:39] = poses.ravel(), twists.ravel()
    numbers[[0, 7]] = twists.ravel()[[5, 11]]
    assert expected[0] == layout.pack(numbers.tolist())  # the one-by-one way is pack()'s bytes
    longer = (np.concatenate((poses.ravel(), [9.0])).tobytes(), twists.tobytes())  # other lengths: a new recipe
    assert filled.pack_many([longer]) == [filled._packed([np.frombuffer(a, "<f8") for a in longer])]
