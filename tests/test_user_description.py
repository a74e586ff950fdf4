"""A user's own description package (package.xml, $(find) includes, STL meshes) builds, drives and runs from the
CLI; a description that lacks what the sim needs is one line and exit code 2."""

from __future__ import annotations

import math
import subprocess
import sys
import warnings
from pathlib import Path

import mujoco
import pytest

from conftest import fit_circle, positions
from racecar_sim import Simulator
from racecar_sim.core.errors import RacecarSimError
from racecar_sim.description import VehicleGeometry
from racecar_sim.drivers import ConstantCommand
from ros_package_helpers import write_description_package

WHEELBASE = 0.40  # m; the seed car's is 0.325
STEER = 0.3  # rad


@pytest.fixture(autouse=True)
def no_user_paths(monkeypatch):
    for variable in ("ROS_PACKAGE_PATH", "GAZEBO_MODEL_PATH"):
        monkeypatch.delenv(variable, raising=False)


def test_a_users_package_with_meshes_drives_a_circle_of_its_own_wheelbase(tmp_path, monkeypatch):
    xacro = write_description_package(tmp_path / "ws", "its_pkg", wheelbase=WHEELBASE, mesh=True)
    monkeypatch.setenv("ROS_PACKAGE_PATH", str(tmp_path / "ws"))
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a box is convex: no warning about hulls
        sim = Simulator(world="empty", xacro=xacro, camera=False, lidar=False)
    with sim:
        wheelbase = VehicleGeometry.from_robot(sim.car.robot).wheelbase
        assert wheelbase == pytest.approx(WHEELBASE, abs=1e-9)
        visual, collision = sim.model.geom("chassis_visual"), sim.model.geom("chassis_collision")
        for geom in (visual, collision):
            assert geom.type[0] == mujoco.mjtGeom.mjGEOM_MESH
            mesh = geom.dataid[0]
            local = sim.model.mesh_vert[sim.model.mesh_vertadr[mesh] :][: sim.model.mesh_vertnum[mesh]]
            world = sim.data.geom_xpos[geom.id] + local @ sim.data.geom_xmat[geom.id].reshape(3, 3).T
            base = sim.data.site("chassis").xpos  # the mesh's <origin> is in the chassis frame
            assert world.max(0) - world.min(0) == pytest.approx([0.12, 0.08, 0.04], abs=1e-3)
            assert (world.max(0) + world.min(0)) / 2 - base == pytest.approx([0.05, 0.0, 0.09], abs=1e-3)
        assert collision.contype[0] == 1 and visual.contype[0] == 0
        odom: list = []
        sim.subscribe("/vesc/odom", odom.append)
        ConstantCommand(sim.bus, sim.scheduler, 1.0, STEER)
        sim.run_until(9.0)
    _, radius = fit_circle(positions(odom, after=3.0))
    assert radius == pytest.approx(WHEELBASE / math.tan(STEER), rel=0.03)
    assert abs(radius - 0.325 / math.tan(STEER)) > 0.2  # and not the seed car's circle


def test_a_non_convex_collision_mesh_collides_as_its_pieces_with_a_warning(tmp_path, monkeypatch):
    import trimesh

    xacro = write_description_package(tmp_path, "its_pkg", mesh=True)
    ring_and_box = trimesh.util.concatenate(
        [
            trimesh.creation.annulus(0.02, 0.04, 0.02),
            trimesh.creation.box((0.05, 0.05, 0.02)).apply_translation((0.1, 0, 0)),
        ]
    )
    ring_and_box.export(xacro.parent.parent / "meshes" / "x.stl")
    monkeypatch.setenv("ROS_PACKAGE_PATH", str(tmp_path))
    with (
        pytest.warns(UserWarning, match="not convex"),
        Simulator(world="empty", xacro=xacro, camera=False, lidar=False) as sim,
    ):
        names = [sim.model.geom(i).name for i in range(sim.model.ngeom)]
    assert "chassis_collision" in names and "chassis_collision#1" in names and "chassis_collision#2" not in names


def _cli(*args: str, env_path: Path | None = None, timeout: float = 120) -> subprocess.CompletedProcess:
    env = {k: v for k, v in __import__("os").environ.items() if k != "ROS_PACKAGE_PATH"}
    return subprocess.run(
        [sys.executable, "-m", "racecar_sim", *args], capture_output=True, text=True, timeout=timeout, env=env
    )


def _one_line_error(result: subprocess.CompletedProcess) -> str:
    assert result.returncode == 2, result.stderr
    assert "Traceback" not in result.stderr
    lines = [line for line in result.stderr.strip().splitlines() if "warning:" not in line]
    assert len(lines) == 1, result.stderr
    return lines[0]


RUN = (
    "run",
    "--world",
    "empty",
    "--duration",
    "1",
    "--no-camera",
    "--no-lidar",
    "--driver",
    "constant",
    "--speed",
    "1",
    "--steering",
    "0.3",
    "--no-record",
    "--no-video",
    "--no-summary",
)


def test_run_takes_a_users_xacro_its_arguments_and_package_path(tmp_path):
    xacro = write_description_package(tmp_path / "ws", "its_pkg", wheelbase=WHEELBASE, mesh=True)
    result = _cli(
        *RUN,
        "--out",
        str(tmp_path / "out"),
        "--xacro",
        str(xacro),
        "--package-path",
        str(tmp_path / "ws"),
        "--xacro-arg",
        "right_steering_hinge_type:=continuous",
    )
    assert result.returncode == 0, result.stderr
    assert "final pose" in result.stdout and "sim time         1.00 s" in result.stdout


def test_run_with_a_missing_package_is_one_line(tmp_path):
    xacro = write_description_package(tmp_path / "ws", "its_pkg")
    line = _one_line_error(_cli(*RUN, "--out", str(tmp_path / "out"), "--xacro", str(xacro)))
    assert "'its_pkg'" in line and str(xacro) in line and "--package-path" in line


@pytest.mark.parametrize(
    "edit, element",
    [
        ({'type="revolute"': 'type="fixed"'}, "steering hinge"),  # with right_steering_hinge_type:=fixed below
        ({'<xacro:steering_hinge_transmission name="left_steering_hinge"/>': ""}, "<transmission>"),
        (
            {
                '<joint name="left_rear_wheel_joint" type="continuous">': (
                    '<joint name="left_rear_axle" type="continuous">'
                )
            },
            "left_rear_wheel_joint",
        ),
    ],
)
def test_run_with_a_car_the_sim_cannot_drive_is_one_line(tmp_path, edit, element):
    xacro = write_description_package(tmp_path / "ws", "its_pkg", edit=edit)
    line = _one_line_error(
        _cli(
            *RUN,
            "--out",
            str(tmp_path / "out"),
            "--xacro",
            str(xacro),
            "--package-path",
            str(tmp_path / "ws"),
            "--xacro-arg",
            "right_steering_hinge_type:=fixed",
        )
    )
    assert str(xacro) in line and element in line


@pytest.mark.parametrize("bad", ["no_assignment", ":=value", "1st:=x", "a b:=c"])
def test_a_malformed_xacro_arg_is_one_line(tmp_path, bad):
    line = _one_line_error(_cli(*RUN, "--xacro-arg", bad, timeout=60))
    assert "--xacro-arg" in line and bad in line


def test_teleop_takes_the_same_options(tmp_path):
    result = _cli("teleop", "--help", timeout=60)
    assert result.returncode == 0
    for option in ("--xacro", "--xacro-arg", "--package-path"):
        assert option in result.stdout


def test_errors_of_a_users_car_are_racecar_sim_errors(tmp_path, monkeypatch):
    xacro = write_description_package(
        tmp_path, "its_pkg", edit={'<xacro:steering_hinge_transmission name="right_steering_hinge"/>': ""}
    )
    monkeypatch.setenv("ROS_PACKAGE_PATH", str(tmp_path))
    with pytest.raises(RacecarSimError, match="right_steering_hinge_joint' has no <transmission>"):
        Simulator(world="empty", xacro=xacro, camera=False, lidar=False)
