"""The original racecar_gazebo and racecar launch files, unchanged, from work trees of their repositories.

Set RACECAR_GAZEBO_SRC and RACECAR_SRC to checkouts of mit-racecar/racecar_gazebo and mit-racecar/racecar (e.g.
`git archive HEAD | tar -x -C DIR`); without them these tests skip. Their packages go on ROS_PACKAGE_PATH; the
packages they include that a sim user lacks (gazebo_ros, ackermann_cmd_mux, xacro, ...) are the sim's stand-ins.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from racecar_sim.launch import LaunchRun, load_launch, map_plan
from racecar_sim.msgs import AckermannDrive, AckermannDriveStamped, Header

GAZEBO_SRC, RACECAR_SRC = os.environ.get("RACECAR_GAZEBO_SRC"), os.environ.get("RACECAR_SRC")
pytestmark = pytest.mark.skipif(
    not (GAZEBO_SRC and RACECAR_SRC),
    reason="RACECAR_GAZEBO_SRC and RACECAR_SRC name no checkouts of the original repositories",
)


@pytest.fixture
def originals(monkeypatch: pytest.MonkeyPatch) -> Path:
    monkeypatch.setenv("ROS_PACKAGE_PATH", os.pathsep.join([GAZEBO_SRC, RACECAR_SRC]))
    return Path(GAZEBO_SRC)


def test_racecar_tunnel_launch_runs_unchanged(originals):
    plan = load_launch(originals / "racecar_gazebo" / "launch" / "racecar_tunnel.launch")
    setup = map_plan(plan, camera=False)
    car_nodes = setup.cars[0].plan
    assert Path(setup.world.world).name == "racecar_tunnel.world"
    assert all(Path(p).is_relative_to(RACECAR_SRC) for p in car_nodes.mux["muxes"].values())  # its own mux YAMLs
    assert car_nodes.servo_input == "/vesc/low_level/ackermann_cmd_mux/output" and car_nodes.odometry
    assert setup.relays == [("/vesc/odom", "/pf/pose/odom")] and not setup.skipped
    with LaunchRun(setup) as run:
        sim = run.sim
        assert sim.world.name == "racecar_tunnel" and sim.car.model_name == "racecar"
        command = AckermannDriveStamped(Header(), AckermannDrive(speed=1.0))
        sim.scheduler.every(20.0, lambda t: sim.publish("/vesc/ackermann_cmd_mux/input/navigation", command), "nav")
        sim.run_until(1.5)
        assert sim.car.chain.in_control() == "Navigation"
        assert 0.7 < sim.car.state.base_pose()[0][0] < 1.6
        assert sim.bus.count("/pf/pose/odom") == 30


def test_racecar_tunnel_launch_from_the_command_line(originals):
    result = subprocess.run(
        [
            sys.executable,
            "-m",
            "racecar_sim",
            "launch",
            str(originals / "racecar_gazebo" / "launch" / "racecar_tunnel.launch"),
            "--duration",
            "2",
            "--no-camera",
        ],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert result.returncode == 0, result.stderr
    assert "world racecar_tunnel, cars racecar" in result.stderr and "Traceback" not in result.stderr
