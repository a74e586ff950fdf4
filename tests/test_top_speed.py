"""The top speed is applied to the command as a whole: near the wheel joints' velocity limit (100 rad/s, 5 m/s on
0.05 m wheels) every wheel is slowed by one factor, so the wheels never fight and the car keeps the commanded path."""

from __future__ import annotations

import math

import numpy as np
import pytest

from conftest import fit_circle, positions
from racecar_sim import Simulator
from racecar_sim.control.servo_law import ServoLaw
from racecar_sim.description import VehicleGeometry, load_robot

GEOMETRY = VehicleGeometry.from_robot(load_robot())
L = GEOMETRY.wheelbase
WHEEL_LIMIT = 100.0  # rad/s, the wheel joints' <limit velocity> in racecar.xacro


@pytest.fixture(scope="module")
def law() -> ServoLaw:
    sim = Simulator(world="empty", camera=False, lidar=False)
    yield sim.car.servo.law
    sim.close()


def split(law: ServoLaw, values: list[float]) -> tuple[list[float], list[float]]:
    rates = [v for v, (_, hinge) in zip(values, law.outputs) if not hinge]
    hinges = [v for v, (_, hinge) in zip(values, law.outputs) if hinge]
    return rates, hinges


@pytest.mark.parametrize("steer", [0.0, 0.06, -0.1, 0.3])
def test_a_command_past_the_top_speed_scales_every_wheel_by_one_factor(law, steer):
    slow_rates, slow_hinges = split(law, law.command(1.0, steer)[0])
    fast_rates, fast_hinges = split(law, law.command(9.0, steer)[0])
    # the fastest wheel at its limit, and the others in the same proportion to it as at 1 m/s
    assert max(abs(r) for r in fast_rates) == pytest.approx(WHEEL_LIMIT, rel=1e-12)
    assert np.allclose(np.array(fast_rates) / max(fast_rates), np.array(slow_rates) / max(slow_rates), rtol=1e-12)
    assert fast_hinges == slow_hinges  # the path (the hinge angles) does not depend on speed
    # backwards likewise
    back_rates, _ = split(law, law.command(-9.0, steer)[0])
    assert min(back_rates) == pytest.approx(-WHEEL_LIMIT, rel=1e-12)


def test_a_command_within_the_limits_is_the_plain_law(law):
    # 4 m/s on a 0.06 rad turn: every wheel below 100 rad/s, so each rate is ground speed / radius exactly
    rates, _ = split(law, law.command(4.0, 0.0)[0])
    assert rates == [4.0 / GEOMETRY.wheel_radius] * 4


def circle_ratio(speed: float, steer: float, vehicle: str = "seed") -> float:
    """R / R0 of the circle driven for 8 s at a constant command, fitted over its last 4 s."""
    from conftest import Log
    from racecar_sim.drivers import ConstantCommand

    sim = Simulator(world="empty", camera=False, lidar=False, vehicle=vehicle)
    log = Log(sim, "/vesc/odom")
    ConstantCommand(sim.bus, sim.scheduler, speed, steer)
    sim.run_until(8.0)
    sim.close()
    _, radius = fit_circle(positions(log["/vesc/odom"], after=4.0))
    return radius / (L / math.tan(steer))


@pytest.mark.parametrize("vehicle", ["seed", "f1tenth"])
def test_past_the_top_speed_the_car_keeps_its_line(vehicle):
    # before: 6.5 m/s at 0.06 rad gave R/R0 = 3.92 for seed (the outer wheels clipped, the car sliding out)
    assert circle_ratio(6.5, 0.06, vehicle) == pytest.approx(circle_ratio(4.8, 0.06, vehicle), rel=0.05)


def test_a_vehicle_sets_steering_and_speed_ranges_clamp_the_command(tmp_path):
    path = tmp_path / "slow.yaml"
    path.write_text("s_min: -0.4189\ns_max: 0.4189\nv_min: -1.0\nv_max: 2.0\n")  # F1TENTH's steering, slow speeds
    sim = Simulator(world="empty", camera=False, lidar=False, vehicle=path)
    law = sim.car.servo.law
    sim.close()
    # F1TENTH's s_max = 0.4189 rad: a sharper command steers as s_max does (the seed's hinges would take 0.6)
    assert law.command(1.0, 0.6)[0] == law.command(1.0, 0.4189)[0]
    assert law.command(1.0, -0.6)[0] == law.command(1.0, -0.4189)[0]
    # within the range, the plain law
    assert law.command(1.0, 0.3)[0] != law.command(1.0, 0.4189)[0]
    # v_min..v_max = -1..2 m/s, well within the wheels' 5 m/s
    assert law.command(3.0, 0.2)[0] == law.command(2.0, 0.2)[0] != law.command(1.9, 0.2)[0]
    assert law.command(-3.0, 0.2)[0] == law.command(-1.0, 0.2)[0]
