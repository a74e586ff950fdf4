"""Topics, rates, stamps, frames and TF, as the original stack publishes them."""

from __future__ import annotations

import math

import numpy as np
import pytest

from conftest import Log
from racecar_sim import Simulator
from racecar_sim.core.transforms import quat_to_matrix
from racecar_sim.description import load_robot
from racecar_sim.description.kinematics import link_pose
from racecar_sim.drivers import ConstantCommand


def stamp_ns(msg) -> int:
    return msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec


def test_message_counts_and_exact_stamps_in_10_s():
    sim = Simulator()
    log = Log(sim, "/vesc/odom", "/racecar/joint_states", "/pf/pose/odom", "/clock")
    sim.run_until(10.0)
    assert len(log["/vesc/odom"]) == 200 and len(log["/pf/pose/odom"]) == 200
    assert len(log["/racecar/joint_states"]) == 500
    assert len(log["/clock"]) == 1000
    assert [stamp_ns(m) for m in log["/vesc/odom"]] == [50_000_000 * k for k in range(1, 201)]
    assert [stamp_ns(m) for m in log["/racecar/joint_states"]] == [20_000_000 * k for k in range(1, 501)]


def test_joint_states_name_the_six_actuated_joints():
    sim = Simulator()
    log = Log(sim, "/racecar/joint_states")
    sim.run_until(0.1)
    msg = log["/racecar/joint_states"][-1]
    assert sorted(msg.name) == sorted(
        f"{n}_joint"
        for n in (
            "left_rear_wheel",
            "right_rear_wheel",
            "left_front_wheel",
            "right_front_wheel",
            "left_steering_hinge",
            "right_steering_hinge",
        )
    )
    assert len(msg.position) == len(msg.velocity) == len(msg.effort) == 6


def test_original_odometry_is_ground_truth_map_to_odom_with_world_twist():
    sim = Simulator()
    log = Log(sim, "/vesc/odom", "/tf")
    ConstantCommand(sim.bus, sim.scheduler, 1.0, 0.3)
    sim.run_until(3.0)
    odom = log["/vesc/odom"][-1]
    assert (odom.header.frame_id, odom.child_frame_id) == ("map", "odom")
    pos, quat = sim.car.state.base_pose()
    p = odom.pose.pose.position
    np.testing.assert_allclose([p.x, p.y, p.z], pos, atol=1e-12)
    # world-frame twist: the velocity vector points along the car's heading in the world
    heading = quat_to_matrix(quat)[:, 0]
    v = odom.twist.twist.linear
    assert np.dot([v.x, v.y], heading[:2]) == pytest.approx(math.hypot(v.x, v.y), rel=0.01)
    tf = [t for m in log["/tf"] for t in m.transforms if t.header.frame_id == "map"]
    assert tf[-1].child_frame_id == "odom" and tf[-1].transform.translation.x == p.x


def test_ros_odometry_mode_is_odom_to_base_link_with_body_twist():
    sim = Simulator(odometry="ros")
    log = Log(sim, "/vesc/odom")
    ConstantCommand(sim.bus, sim.scheduler, 1.0, 0.3)
    sim.run_until(3.0)
    odom = log["/vesc/odom"][-1]
    assert (odom.header.frame_id, odom.child_frame_id) == ("odom", "base_link")
    v = odom.twist.twist.linear
    assert v.x == pytest.approx(1.0, rel=0.02) and abs(v.y) < 0.05  # body frame: forward speed on x
    assert odom.twist.twist.angular.z == pytest.approx(1.0 * math.tan(0.3) / 0.325, rel=0.05)


def test_tf_tree_matches_the_urdf():
    robot = load_robot()
    sim = Simulator()
    log = Log(sim, "/tf_static", "/tf")  # /tf_static is latched: a late subscriber still gets it
    ConstantCommand(sim.bus, sim.scheduler, 1.0, 0.2)
    sim.run_until(2.0)
    static = {t.child_frame_id: t for t in log["/tf_static"][0].transforms}
    assert set(static) == {
        "chassis",
        "chassis_inertia",
        "laser",
        "zed_camera_link",
        "camera_link",
        "zed_camera_right_link",
    }
    laser = static["laser"].transform.translation
    assert (static["laser"].header.frame_id, laser.x, laser.y, laser.z) == ("chassis", 0.265, 0.0, 0.075)
    moving = {t.child_frame_id: t for m in log["/tf"][-3:] for t in m.transforms}
    for wheel in ("left_rear_wheel", "right_front_wheel", "left_steering_hinge"):
        assert wheel in moving
    # the published hinge rotation equals FK of the URDF at the joint state's angle
    hinge = moving["left_steering_hinge"].transform.rotation
    angle = sim.data.joint("left_steering_hinge_joint").qpos[0]
    _, q = link_pose(robot, "left_steering_hinge", {"left_steering_hinge_joint": angle})  # chassis is not rotated
    assert abs(np.dot([hinge.w, hinge.x, hinge.y, hinge.z], q)) == pytest.approx(1.0, abs=1e-9)
    assert angle > 0.1  # the hinge really turned
