"""Spawn poses are checked against the built world (issue 10, item 6): inside an obstacle, below the ground or
over nothing is a one-line error (exit code 2), high above the ground a warning; and a world whose models have
no materials at all is seen by the lidar (item 8)."""

from __future__ import annotations

import math
import re
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

from conftest import laser_pose
from racecar_sim import Simulator
from racecar_sim.core.errors import WorldError
from racecar_sim.core.transforms import compose, quat_rotate, yaw_of
from racecar_sim.worlds import Spawn, load_world, world_names

RUN = ["--duration", "0.5", "--no-camera", "--no-record", "--no-summary", "--no-video"]


def run_cli(tmp_path: Path, world: str, spawn: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "racecar_sim", "run", "--world", world, "--spawn", spawn, *RUN],
        capture_output=True,
        text=True,
        timeout=120,
        cwd=tmp_path,
    )


def one_error_line(result: subprocess.CompletedProcess) -> str:
    assert result.returncode == 2, result.stderr
    assert "Traceback" not in result.stderr
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1, result.stderr
    return lines[0]


def collision_boxes(world_name: str) -> list[tuple[str, np.ndarray, np.ndarray, tuple[float, ...]]]:
    """(geom name, world centre, world orientation, full size) of the world's collision boxes, from its own geoms."""
    boxes = []
    for body, geom in load_world(world_name).geoms(collides=True):
        if geom.kind == "box":
            pos, quat = compose(body.pos, body.quat, geom.pos, geom.quat)
            boxes.append((geom.name, pos, quat, geom.size))
    return boxes


def inside_a_tunnel_wall() -> tuple[str, float, float, float]:
    """The middle of the tunnel's longest wall, and the wall's heading: a car there lies inside it."""
    name, pos, quat, _ = max(collision_boxes("tunnel"), key=lambda box: box[3][0])
    return name, float(pos[0]), float(pos[1]), yaw_of(quat)


def off_the_walker_course() -> tuple[float, float]:
    """5 m beyond the east edge of everything the walker racecourse is made of (it has no ground plane)."""
    signs = np.array([(sx, sy, sz) for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)])
    corners = np.array(
        [
            pos + quat_rotate(quat, 0.5 * s * np.array(size))
            for _, pos, quat, size in collision_boxes("walker")
            for s in signs
        ]
    )
    return float(corners[:, 0].max() + 5.0), float(corners[:, 1].mean())


def simulator(world: str, spawn: Spawn | None = None) -> Simulator:
    return Simulator(world=world, spawn=spawn, camera=False, lidar=False)


# --- errors: inside a wall, below the ground, over nothing --------------------------------------------------------
def test_spawn_inside_a_tunnel_wall_is_an_error():
    wall, x, y, yaw = inside_a_tunnel_wall()
    with pytest.raises(
        WorldError,
        match=r"^tunnel \(racecar_tunnel\.world\): spawn pose .* is inside an obstacle: "
        r".* into " + re.escape(wall),
    ):
        simulator("tunnel", Spawn(x, y, 0.05, yaw))


def test_spawn_inside_a_tunnel_wall_fails_in_one_line_from_the_cli(tmp_path):
    wall, x, y, yaw = inside_a_tunnel_wall()
    line = one_error_line(run_cli(tmp_path, "tunnel", f"{x},{y},{yaw}"))
    assert line.startswith("racecar-sim: error: --spawn: tunnel (racecar_tunnel.world): spawn pose")
    assert "inside an obstacle" in line and line.endswith(f"into {wall}")


def test_spawn_below_the_ground_is_an_error(tmp_path):
    with pytest.raises(
        WorldError,
        match=r"^empty \(racecar\.world\): spawn pose \(0, 0, -0\.3, 0\) is below the "
        r"ground: .* 0\.3 m under the surface of ground_plane",
    ):
        simulator("empty", Spawn(0.0, 0.0, -0.3, 0.0))
    line = one_error_line(run_cli(tmp_path, "empty", "0,0,-0.3,0"))
    assert "empty (racecar.world): spawn pose (0, 0, -0.3, 0) is below the ground" in line


def test_spawn_off_the_walker_course_has_no_ground(tmp_path):
    x, y = off_the_walker_course()
    with pytest.raises(WorldError, match=r"^walker \(racecar_walker\.world\): spawn pose .* has no ground under it"):
        simulator("walker", Spawn(x, y, 0.05, 0.0))
    line = one_error_line(run_cli(tmp_path, "walker", f"{x},{y},0"))
    assert "walker (racecar_walker.world)" in line and "has no ground under it" in line


# --- a warning: high above the ground ------------------------------------------------------------------------------
def test_spawn_two_metres_up_warns_of_the_fall(tmp_path):
    with pytest.warns(
        UserWarning,
        match=r"^empty \(racecar\.world\): spawn pose \(0, 0, 2, 0\) is 2 m above the "
        r"ground: the car will fall 2 m$",
    ):
        simulator("empty", Spawn(0.0, 0.0, 2.0, 0.0))
    result = run_cli(tmp_path, "empty", "0,0,2,0")
    assert result.returncode == 0, result.stderr
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and "will fall 2 m" in lines[0] and lines[0].startswith("racecar-sim: warning: empty"), (
        result.stderr
    )


# --- the built-in worlds' own spawn poses pass, quietly ------------------------------------------------------------
@pytest.mark.parametrize("name", world_names())
def test_default_spawns_of_the_builtin_worlds_pass_without_a_warning(name):
    from racecar_sim.physics import check_spawn

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        sim = simulator(name)
        check_spawn(sim.model, sim.data, sim.world, sim.car.robot)  # called again on the built model: still quiet


# --- item 8: no materials anywhere -----------------------------------------------------------------------------------
CRATE_X, CRATE_SIDE = 2.0, 0.5  # m, a crate straight ahead of the car


def bare_world(folder: Path) -> Path:
    """A floor and a crate, with collision and visual shapes but no <material> anywhere (and no plane, which would
    get a checker material)."""

    def model(name: str, pose: str, size: str) -> str:
        shape = f"<geometry><box><size>{size}</size></box></geometry>"
        return (
            f"<model name='{name}'><static>true</static><pose>{pose}</pose><link name='l'>"
            f"<collision name='c'>{shape}</collision><visual name='v'>{shape}</visual></link></model>"
        )

    path = folder / "bare.world"
    path.write_text(
        f"<sdf version='1.6'><world name='bare'>{model('floor', '0 0 -0.05 0 0 0', '20 20 0.1')}"
        f"{model('crate', f'{CRATE_X} 0 0.5 0 0 0', f'{CRATE_SIDE} {CRATE_SIDE} 1')}</world></sdf>"
    )
    return path


def test_lidar_sees_a_world_with_no_materials(tmp_path):
    sim = Simulator(world=str(bare_world(tmp_path)), camera=False, sensor_noise=False)
    assert sim.model.nmat == 0, "the world and the car must have no materials for this test to mean anything"
    scans: list = []
    sim.subscribe("/scan", scans.append)
    sim.run_until(0.05)
    scan = scans[-1]
    # the laser's ray origin from the URDF chain and the sensor <pose>, not from the caster
    origin, laser_quat = laser_pose(sim)
    heading = yaw_of(laser_quat)
    ahead = round((-heading - scan.angle_min) / scan.angle_increment)  # the beam pointing along +x
    beam = scan.angle_min + ahead * scan.angle_increment + heading
    assert abs(beam) < 1e-6
    expected = (CRATE_X - CRATE_SIDE / 2 - origin[0]) / math.cos(beam)
    assert float(scan.ranges[ahead]) == pytest.approx(expected, abs=1e-4)
    assert np.isinf(scan.ranges[0]) and np.isinf(scan.ranges[-1]), "nothing behind the car within 10 m"
