"""The seed's numbers are in the expanded URDF and in the MuJoCo model built from it."""

from __future__ import annotations

import subprocess
import sys
import xml.etree.ElementTree as ET

import mujoco
import numpy as np
import pytest

from racecar_sim import Simulator
from racecar_sim.core.errors import DescriptionError
from racecar_sim.description import VehicleGeometry, expand_xacro, load_robot, parse_urdf

WHEELS = ["left_rear_wheel", "right_rear_wheel", "left_front_wheel", "right_front_wheel"]
HINGES = ["left_steering_hinge", "right_steering_hinge"]


@pytest.fixture(scope="module")
def robot():
    return load_robot()


def test_links_masses_and_inertias(robot):
    chassis = robot.links["chassis_inertia"].inertial
    assert chassis.mass == 4.0
    assert chassis.inertia[:3] == (0.010609, 0.050409, 0.05865)
    assert chassis.origin.xyz == (0.1477, 0.0, 0.0)
    for w in WHEELS:
        i = robot.links[w].inertial
        assert i.mass == pytest.approx(0.34, abs=0.001)  # the seed rounds 0.34055
        assert i.inertia[:3] == (0.00026046, 0.00026046, 0.00041226)
        side = 1 if w.startswith("left") else -1
        assert i.origin.xyz == (0.0, 0.0, -side * 0.0225)  # right wheels +0.0225 on z, left -0.0225
    for h in HINGES:
        assert robot.links[h].inertial.mass == 0.100
        assert robot.links[h].inertial.inertia[:3] == (4e-6, 4e-6, 4e-6)
    assert robot.links["laser"].inertial.mass == 0.130
    assert robot.links["laser"].inertial.inertia[:3] == (4e-6, 4e-6, 4e-6)
    assert robot.links["zed_camera_link"].inertial.mass == 1e-5
    assert robot.links["zed_camera_link"].inertial.inertia[:3] == (1e-6, 1e-6, 1e-6)


def test_collision_shapes(robot):
    for w in WHEELS:
        (shape,) = robot.links[w].collisions
        assert shape.geometry.kind == "cylinder"
        assert shape.geometry.size[:2] == (0.05, 0.045)
        assert shape.origin.xyz[2] == (-0.0225 if w.startswith("left") else 0.0225)
        assert shape.origin.rpy == (0.0, 0.0, 0.0)
    assert robot.links["laser"].collisions[0].geometry.size == (0.1, 0.1, 0.1)
    assert robot.links["zed_camera_link"].collisions[0].geometry.size == (0.033, 0.175, 0.030)
    assert robot.links["chassis"].collisions == []  # the original chassis has no collision geometry


def test_joint_limits(robot):
    for w in WHEELS:
        j = robot.joints[f"{w}_joint"]
        assert j.type == "continuous" and j.limit.effort == 10 and j.limit.velocity == 100
        assert j.origin.rpy == (1.5708, 0.0, 0.0)
    for h in HINGES:
        j = robot.joints[f"{h}_joint"]
        assert j.type == "revolute"  # the seed: both hinges revolute
        assert (j.limit.lower, j.limit.upper, j.limit.effort, j.limit.velocity) == (-1.0, 1.0, 10, 100)
        assert j.origin.rpy == (0.0, 1.5708, 0.0)
    assert robot.joints["hokuyo_joint"].type == "fixed"
    assert robot.joints["zed_camera_joint"].type == "fixed"


def test_gazebo_surfaces_and_transmissions(robot):
    for w in WHEELS:
        s = robot.links[w].surface
        assert (s.mu1, s.mu2, s.kp, s.kd) == (1.0, 1.0, 1e7, 1.0)
        assert s.fdir1 == ((1.0, 0.0, 0.0) if "rear" in w else (0.0, 0.0, 1.0))
    chassis = robot.links["chassis"].surface
    assert (chassis.mu1, chassis.mu2, chassis.kp, chassis.kd) == (0.0, 0.0, 1e7, 1.0)
    assert sorted(t.joint for t in robot.transmissions) == sorted([f"{n}_joint" for n in WHEELS + HINGES])
    assert all(t.hardware_interface == "EffortJointInterface" and t.reduction == 1 for t in robot.transmissions)
    (control,) = robot.plugins
    assert (control.name, control.filename) == ("gazebo_ros_control", "libgazebo_ros_control.so")
    assert control.params["robotNamespace"] == "/racecar" and control.link is None


def test_sensor_blocks(robot):
    laser = robot.sensor("ray")
    assert laser.link == "laser" and laser.update_rate == 40 and laser.pose.xyz == (0, 0, 0.0124)
    ray = laser.element.find("ray")
    assert int(ray.findtext("scan/horizontal/samples")) == 1081
    assert float(ray.findtext("scan/horizontal/min_angle")) == pytest.approx(-2.356, abs=1e-3)
    assert float(ray.findtext("scan/horizontal/max_angle")) == pytest.approx(2.356, abs=1e-3)
    assert (float(ray.findtext("range/min")), float(ray.findtext("range/max"))) == (0.1, 10.0)
    assert (float(ray.findtext("noise/mean")), float(ray.findtext("noise/stddev"))) == (0.0, 0.01)
    assert laser.element.find("plugin/topicName").text == "/scan"
    camera = robot.sensor("camera")
    assert camera.link == "camera_link" and camera.update_rate == 30
    cam = camera.element.find("camera")
    assert (int(cam.findtext("image/width")), int(cam.findtext("image/height"))) == (640, 480)
    assert cam.findtext("image/format") == "B8G8R8"
    assert (float(cam.findtext("clip/near")), float(cam.findtext("clip/far"))) == (0.02, 300)
    assert (cam.findtext("noise/type"), float(cam.findtext("noise/stddev"))) == ("gaussian", 0.007)
    # fx = 687.8066 and cx = 320.5 follow from this field of view
    fx = 320 / np.tan(float(cam.findtext("horizontal_fov")) / 2)
    assert fx == pytest.approx(687.8066, abs=1e-3)


def test_derived_dimensions(robot):
    g = VehicleGeometry.from_robot(robot)
    assert g.wheelbase == pytest.approx(0.325)
    assert g.kingpin_track == pytest.approx(0.20)
    assert g.tyre_track == pytest.approx(0.245, abs=1e-6)
    assert (g.wheel_radius, g.wheel_width) == (0.05, 0.045)
    assert g.total_mass == pytest.approx(5.69223)


def test_mujoco_model_merges_fixed_links_like_gazebo():
    sim = Simulator()
    m = sim.model
    car = m.body("base_link").id
    bodies = {m.body(i).name for i in range(1, m.nbody) if m.body_rootid[i] == car}
    assert bodies == {"base_link", *WHEELS, *HINGES}  # Gazebo's 7 links
    assert all(m.body_jntnum[i] == 0 for i in range(1, m.nbody) if m.body_rootid[i] != car)  # the rest: static world
    base = m.body("base_link")
    assert base.mass[0] == pytest.approx(4.13003)  # chassis + laser + the three camera links
    # centre of mass of the merged base: mass-weighted mean of its parts (original_stack.md §1.4)
    expected_com = (
        4.0 * np.array([0.1477, 0, 0.05]) + 0.13 * np.array([0.265, 0, 0.125]) + 1e-5 * (np.array([0.39, 0, 0.09]) * 3)
    ) / 4.13003
    np.testing.assert_allclose(base.ipos, expected_com, atol=1e-6)
    assert m.body_subtreemass[base.id] == pytest.approx(5.69223)
    for h in HINGES:
        np.testing.assert_allclose(m.jnt_range[m.joint(f"{h}_joint").id], [-1.0, 1.0])
    for name in [f"{n}_joint" for n in WHEELS + HINGES]:
        np.testing.assert_allclose(m.jnt_actfrcrange[m.joint(name).id], [-10.0, 10.0])
    for site in ("laser", "camera_link", "zed_camera_right_link", "chassis"):
        assert mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE, site) >= 0
    np.testing.assert_allclose(sim.data.site("laser").xpos, [0.265, 0, 0.125 + 0.05], atol=1e-3)


def test_friction_follows_gazebo_min_rule():
    m = Simulator().model
    wheel, ground = m.geom("left_rear_wheel_collision"), m.geom("ground_plane::link/collision")
    assert ground.friction[0] == 100.0 and wheel.friction[0] == 1.0
    # MuJoCo uses the higher-priority geom's friction: the wheel's 1.0 = min(1, 100), as Gazebo
    assert wheel.priority[0] > ground.priority[0]


def test_xacro_arguments_change_the_model():
    original = Simulator(profile="mit-2017").model
    assert original.jnt_limited[original.joint("right_steering_hinge_joint").id] == 0  # continuous, as in 2017
    assert original.jnt_limited[original.joint("left_steering_hinge_joint").id] == 1
    urdf = expand_xacro(args={"right_steering_hinge_type": "continuous"})
    joint = next(j for j in ET.fromstring(urdf).iter("joint") if j.get("name") == "right_steering_hinge_joint")
    assert joint.get("type") == "continuous"


def test_disable_laser_environment_variable(monkeypatch):
    monkeypatch.setenv("DISABLE_GAZEBO_LASER", "true")
    robot = load_robot()
    assert robot.sensor("ray") is None and robot.sensor("camera") is not None


def test_malformed_urdf_names_the_problem():
    with pytest.raises(DescriptionError, match="malformed XML"):
        parse_urdf("<robot><link name='a'></robot>", source="bad.urdf")
    with pytest.raises(DescriptionError, match="joint j: link 'nowhere' is not defined"):
        parse_urdf(
            "<robot name='r'><link name='a'/><joint name='j' type='fixed'><parent link='a'/>"
            "<child link='nowhere'/></joint></robot>",
            source="bad.urdf",
        )
    with pytest.raises(DescriptionError, match="mass -1.0 must be positive"):
        parse_urdf(
            "<robot name='r'><link name='a'><inertial><mass value='-1'/>"
            "<inertia ixx='1' iyy='1' izz='1'/></inertial></link></robot>",
            source="bad.urdf",
        )


def test_describe_cli_prints_urdf_and_table():
    urdf = subprocess.run(
        [sys.executable, "-m", "racecar_sim", "describe", "--urdf"], capture_output=True, text=True, check=True
    ).stdout
    assert parse_urdf(urdf).joints["left_steering_hinge_joint"].limit.upper == 1.0
    table = subprocess.run(
        [sys.executable, "-m", "racecar_sim", "describe"], capture_output=True, text=True, check=True
    ).stdout
    assert "wheelbase 0.3250 m" in table and "total mass 5.69223 kg" in table
    assert "right_steering_hinge_joint  revolute" in table
    # every column fits its widest cell: each row's cells start where the header's do, two spaces after the last
    joints = table.split("\nJOINT", 1)[1].split("\n\n", 1)[0].splitlines()
    starts = [joints[0].index(h) + len("JOINT") for h in ("TYPE", "PARENT -> CHILD", "LIMITS")]
    for row in joints[1:]:
        assert all(row[i - 2 : i] == "  " and row[i] != " " for i in starts), row
    assert "right_steering_hinge -> right_front_wheel  effort 10 N m" in table


def test_derived_dimensions_once_per_description_and_each_descriptions_own(robot):
    """A fleet's cars share one parsed description, so its geometry is derived once; a description of other
    dimensions (the front axle 0.1 m further forward) still gets its own, 0.1 m longer wheelbase."""
    import copy
    import dataclasses
    import gc

    from racecar_sim.description import vehicle

    first = VehicleGeometry.from_robot(robot)
    assert VehicleGeometry.from_robot(robot) is first
    longer = copy.deepcopy(robot)
    for hinge in HINGES:  # the steering hinges carry the front wheels: moving them moves the front axle
        joint = longer.joints[f"{hinge}_joint"]
        x, y, z = joint.origin.xyz
        longer.joints[joint.name] = dataclasses.replace(
            joint, origin=dataclasses.replace(joint.origin, xyz=(x + 0.1, y, z))
        )
    assert VehicleGeometry.from_robot(longer).wheelbase == pytest.approx(first.wheelbase + 0.1)
    assert VehicleGeometry.from_robot(robot) is first
    key = id(longer)
    del longer
    gc.collect()
    assert key not in vehicle._DERIVED  # the answer goes with its description
