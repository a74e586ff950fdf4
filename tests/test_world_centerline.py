"""A World knows its own centerline (set by its loader), and everything asks the world, not the file's suffix: the
progress reward, pure-pursuit's default path, and the starting row (written once, worlds/row.py) that both
`racecar-sim run --cars N` and the race env use."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from racecar_sim.core.errors import ConfigError
from racecar_sim.envs import RaceEnv
from racecar_sim.envs.reward import world_centerline
from racecar_sim.runtime.driving import attach_driver
from racecar_sim.runtime.simulator import Simulator
from racecar_sim.worlds import Centerline, Spawn, load_world, row_centerline, starting_row

R = 6.0  # m, radius of the circle track


def circle_track(folder: Path, name: str = "circle.csv") -> Path:
    """An anticlockwise circle of radius R about the origin, 2 m wide, starting at (R, 0)."""
    angles = np.linspace(0.0, 2 * math.pi, 120, endpoint=False)
    path = folder / name
    path.write_text(
        "# x_m, y_m, w_tr_right_m, w_tr_left_m\n"
        + "".join(f"{R * math.cos(a):.9f}, {R * math.sin(a):.9f}, 1.0, 0.8\n" for a in angles)
    )
    return path


def test_the_loader_gives_each_world_its_centerline(tmp_path):
    track = load_world(circle_track(tmp_path))
    assert track.is_track and track.centerline.closed and track.centerline.points.shape == (120, 2)
    assert track.centerline.widths.tolist() == [[1.0, 0.8]] * 120  # right, left
    assert track.centerline.length == pytest.approx(2 * math.pi * R, rel=1e-3)
    walker = load_world("walker")  # the racecourse's line for the reward, from worlds.yaml; not a track
    assert walker.centerline is not None and walker.centerline.closed and not walker.is_track
    assert walker.centerline.points[0].tolist() == [-6.0, 0.3]
    assert load_world("empty").centerline is None and not load_world("empty").is_track
    assert world_centerline(track) is track.centerline and world_centerline(walker) is walker.centerline


def test_a_world_built_in_code_is_asked_not_its_file_name(tmp_path):
    world = load_world("empty")  # an SDF world, given a track's centerline in code
    world.centerline = Centerline(
        np.array([[0.0, 0.0], [10.0, 0.0], [10.0, 10.0], [0.0, 10.0]]), True, "square", widths=np.ones((4, 2))
    )
    assert world.is_track and world_centerline(world) is world.centerline
    np.testing.assert_allclose([(s.x, s.y) for s in starting_row(world, 3, 4.0)], [(0, 0), (0, 4), (0, 8)], atol=1e-12)
    sim = Simulator(world=world, camera=False, lidar=False)
    try:
        driver = attach_driver(sim, sim.car, "pure-pursuit")  # no path: the track's centerline, a loop
        assert driver.path.closed and driver.path.points.tolist() == world.centerline.points.tolist()
        world.centerline = None
        with pytest.raises(ConfigError, match="pure-pursuit needs a path"):
            attach_driver(sim, sim.car, "pure-pursuit")
    finally:
        sim.close()


def test_the_row_follows_the_centerline_only_from_its_start(tmp_path):
    track = load_world(circle_track(tmp_path))
    assert row_centerline(track) is track.centerline.points
    row = starting_row(track, 4, 1.5)
    angles = np.unwrap([math.atan2(s.y, s.x) for s in row])
    assert np.hypot([s.x for s in row], [s.y for s in row]) == pytest.approx(R, abs=0.01)
    assert np.diff(angles) * R == pytest.approx(-1.5, abs=0.01)  # back along the track, which runs anticlockwise
    moved = load_world(circle_track(tmp_path), spawn=Spawn(R, 0.5, 0.05, math.pi / 2))  # spawned off its start
    assert row_centerline(moved) is None
    np.testing.assert_allclose([(s.x, s.y) for s in starting_row(moved, 2, 1.5)], [(R, 0.5), (R, -1.0)], atol=1e-12)
    assert row_centerline(load_world("walker")) is None  # walker's spawn is not on its line's first point


def test_the_race_env_lines_its_cars_up_round_a_track(tmp_path):
    env = RaceEnv(num_cars=3, world=circle_track(tmp_path), sensor_noise=False)
    try:
        spawns = [car.spawn for car in env.sim.cars]
        assert np.hypot([s.x for s in spawns], [s.y for s in spawns]) == pytest.approx(R, abs=0.01)
        angles = np.unwrap([math.atan2(s.y, s.x) for s in spawns])
        assert np.diff(angles) * R == pytest.approx(-1.5, abs=0.01)
        heading = [math.remainder(s.yaw - a - math.pi / 2, 2 * math.pi) for s, a in zip(spawns, angles)]
        assert np.abs(heading) == pytest.approx(0.0, abs=0.05)  # each facing the way the track runs
    finally:
        env.close()
