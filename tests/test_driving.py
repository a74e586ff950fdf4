"""The car rests, drives straight and turns as the seed's numbers say, in both driving profiles."""

from __future__ import annotations

import math

import numpy as np
import pytest

from conftest import fit_circle, ground_speed, positions
from racecar_sim import Simulator
from racecar_sim.description import VehicleGeometry, load_robot

GEOMETRY = VehicleGeometry.from_robot(load_robot())
L, T, R_WHEEL = GEOMETRY.wheelbase, GEOMETRY.kingpin_track, GEOMETRY.wheel_radius
GRAVITY = 9.8
KP_GAZEBO = 1e7  # N/m, racecar.gazebo


def hinge_angles(joint_states) -> tuple[float, float]:
    pos = dict(zip(joint_states.name, joint_states.position))
    return pos["left_steering_hinge_joint"], pos["right_steering_hinge_joint"]


def test_rests_on_its_wheels_without_drifting(drive):
    sim, log = drive(0.0, 0.0, 10.0)
    start, end = positions(log["/vesc/odom"])[[0, -1]]
    assert np.linalg.norm(end - start) < 1e-3
    pos, _ = sim.car.state.base_pose()
    # base_link is the ground point under the rear axle: the wheel centres sit one wheel radius up
    for wheel in ("left_rear_wheel", "right_front_wheel"):
        assert sim.data.site(wheel).xpos[2] == pytest.approx(R_WHEEL, abs=1e-4)
    # penetration comparable to Gazebo's static tyre deflection m g / (4 kp) = 1.4 um
    gazebo_deflection = GEOMETRY.total_mass * GRAVITY / (4 * KP_GAZEBO)
    assert abs(pos[2]) < 5 * gazebo_deflection


@pytest.mark.parametrize("physics", ["default", "gazebo"])
def test_seed_profile_commanded_speed_is_ground_speed(drive, physics):
    _, log = drive(1.0, 0.0, 4.0, physics=physics)
    after_2s = [o for o in log["/vesc/odom"] if o.header.stamp.sec >= 2]
    assert all(ground_speed(o) == pytest.approx(1.0, rel=0.02) for o in after_2s)
    assert abs(after_2s[-1].pose.pose.position.y) < 0.02  # straight: < 0.5 % of the 4 m driven


def test_seed_profile_circle_radius_matches_wheelbase_over_tan_steering(drive):
    steer = 0.2
    _, log = drive(1.0, steer, 14.0)
    _, radius = fit_circle(positions(log["/vesc/odom"], after=4.0))
    assert radius == pytest.approx(L / math.tan(steer), rel=0.03)
    # formula (2): the inner (left) hinge turns more than the outer one, by the seed's amounts
    turn = L / math.tan(steer)
    left, right = hinge_angles(log["/racecar/joint_states"][-1])
    assert left > right > 0
    assert left == pytest.approx(math.atan(L / (turn - T / 2)), abs=0.01)
    assert right == pytest.approx(math.atan(L / (turn + T / 2)), abs=0.01)


def test_right_turn_mirrors_left_turn(drive):
    _, log = drive(1.0, -0.2, 6.0)
    left, right = hinge_angles(log["/racecar/joint_states"][-1])
    assert right < left < 0  # now the right hinge is the inner one
    assert log["/vesc/odom"][-1].pose.pose.position.y < -0.5


def test_mit_2017_profile_drives_at_half_the_command(drive):
    _, log = drive(1.0, 0.0, 4.0, profile="mit-2017")
    after_2s = [o for o in log["/vesc/odom"] if o.header.stamp.sec >= 2]
    # servo_commands sends speed / 0.1 rad/s to wheels of radius 0.05 m: 0.5 m/s on the ground
    assert all(ground_speed(o) == pytest.approx(1.0 / 0.1 * R_WHEEL, rel=0.05) for o in after_2s)


def test_mit_2017_profile_steers_both_hinges_alike():
    sim = Simulator(profile="mit-2017")
    commands = {}
    for side in ("left", "right"):
        topic = f"/racecar/{side}_steering_hinge_position_controller/command"
        sim.subscribe(topic, lambda msg, side=side: commands.__setitem__(side, msg.data))
    from racecar_sim.drivers import ConstantCommand

    ConstantCommand(sim.bus, sim.scheduler, 0.0, 0.3)
    states = []
    sim.subscribe("/racecar/joint_states", states.append)
    sim.run_until(5.0)
    assert commands == {"left": pytest.approx(0.3), "right": pytest.approx(0.3)}
    left, right = hinge_angles(states[-1])
    assert left == pytest.approx(right, abs=0.01)


def test_hinges_stay_within_limits_and_efforts_within_ten(drive):
    _, log = drive(3.0, 1.5, 4.0)  # asks for more steering than the joints allow
    states = log["/racecar/joint_states"]
    hinges = np.array([hinge_angles(s) for s in states])
    assert np.abs(hinges).max() <= 1.0 + 1e-3
    assert np.abs(hinges).max() > 0.9  # the inner hinge did reach its stop
    assert max(np.abs(s.effort).max() for s in states) <= 10.0 + 1e-9
