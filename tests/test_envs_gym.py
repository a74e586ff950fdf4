"""The Gymnasium driving env: API conformance, determinism, reset hygiene, vector envs, crashes and progress."""

from __future__ import annotations

import math
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

from conftest import GL_MISSING, needs_gl
from racecar_sim import envs
from racecar_sim.core.errors import ConfigError
from racecar_sim.envs import DRIVE_CAMERA_ID, DRIVE_ID, ENV_IDS
from racecar_sim.envs.drive import CRASH_PENALTY
from racecar_sim.envs.reward import Centerline
from racecar_sim.envs.spaces import (
    MAX_SPEED,
    steering_from_hinges,
    to_command,
)
from racecar_sim.worlds import world_names

FORWARD = np.array([1.0, 0.0], np.float32)


def actions(
    count: int, seed: int = 7, low: tuple[float, float] = (-0.3, -1.0), high: tuple[float, float] = (1.0, 1.0)
) -> np.ndarray:
    """A fixed, varied action sequence (float32, within the normalised box)."""
    return np.random.default_rng(seed).uniform(low, high, (count, 2)).astype(np.float32)


def same(a: dict, b: dict) -> bool:
    return a.keys() == b.keys() and all(np.array_equal(a[k], b[k]) for k in a)


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_check_env_on_every_registered_id(env_id: str) -> None:
    assert env_id in gym.registry
    if env_id == DRIVE_CAMERA_ID and GL_MISSING:
        pytest.skip(GL_MISSING)
    env = gym.make(env_id)
    try:
        check_env(env.unwrapped, skip_render_check=True)
        assert env.spec.max_episode_steps == envs.MAX_EPISODE_STEPS
    finally:
        env.close()


def test_spaces_follow_the_sensor_and_the_joystick_ranges() -> None:
    env = gym.make(DRIVE_ID)
    scan = env.observation_space["scan"]
    assert scan.shape == (1081,) and scan.dtype == np.float32  # racecar.gazebo's Hokuyo: 1081 samples
    assert scan.low[0] == np.float32(0.1) and scan.high[0] == np.float32(10.0)
    assert env.action_space == gym.spaces.Box(-1.0, 1.0, (2,), np.float32)
    raw = gym.make(DRIVE_ID, action="raw").action_space
    np.testing.assert_allclose(raw.high, [2.0, 0.34], rtol=1e-7)  # joy_teleop.yaml's scales
    np.testing.assert_allclose(to_command(np.array([0.5, -1.0]), "normalized"), [1.0, -0.34])
    np.testing.assert_allclose(to_command(np.array([9.0, 0.1]), "raw"), [MAX_SPEED, 0.1])
    obs, _ = env.reset(seed=0)
    assert env.observation_space.contains(obs)
    with pytest.raises(ConfigError, match="control_rate"):
        gym.make(DRIVE_ID, control_rate=4.0)  # slower than the mux's 0.2 s navigation timeout
    env.close()


def test_measured_steering_inverts_the_ackermann_law() -> None:
    # hinge angles formula (2) gives for a bicycle angle of 0.3 rad, wheelbase 0.325, hinges at y = +-0.1
    kappa = math.tan(0.3) / 0.325
    hinges = np.array([[0.325, 0.1], [0.325, -0.1]])
    angles = [math.atan2(x * kappa, 1.0 - kappa * y) for x, y in hinges]
    assert abs(angles[0] - angles[1]) > 0.02  # inner and outer differ
    assert steering_from_hinges(np.array(angles), hinges, 0.325) == pytest.approx(0.3, abs=1e-12)


def test_same_seed_same_rollout_and_other_seeds_other_noise() -> None:
    sequence = actions(200)
    runs = []
    for seed in (3, 3, 4):
        env = gym.make(DRIVE_ID)
        obs, _ = env.reset(seed=seed)
        trace = [obs]
        for action in sequence:
            obs, _, terminated, truncated, _ = env.step(action)
            trace.append(obs)
            if terminated or truncated:
                obs, _ = env.reset()
                trace.append(obs)
        runs.append(trace)
        env.close()
    assert len(runs[0]) == len(runs[1]) and all(same(a, b) for a, b in zip(runs[0], runs[1]))
    # another seed: the pose is the same at reset, only the sensor noise differs
    first, other = runs[0][0]["scan"], runs[2][0]["scan"]
    assert not np.array_equal(first, other)
    assert np.abs(first - other).max() < 0.1  # noise of stddev 1 cm, not another place


def test_reset_leaves_nothing_of_the_last_episode() -> None:
    used = gym.make(DRIVE_ID)
    used.reset(seed=1)
    for action in actions(50, seed=2, low=(0.5, -0.3), high=(1.0, 0.3)):
        used.step(action)
    assert abs(used.unwrapped.agent.speed()) > 0.3
    obs, _ = used.reset(seed=5)
    fresh = gym.make(DRIVE_ID)
    fresh_obs, _ = fresh.reset(seed=5)
    assert same(obs, fresh_obs)
    assert obs["speed"][0] == 0.0 and used.unwrapped.sim.time == 0.0
    # no held command, mux state or controller integral: the next steps match the fresh env's exactly
    for action in actions(30, seed=9):
        a, b = used.step(action), fresh.step(action)
        assert same(a[0], b[0]) and a[1:4] == b[1:4]
    used.close()
    fresh.close()


@pytest.mark.parametrize("control_rate", [20.0, 30.0])
def test_the_scan_observed_is_the_latest_scan_published(control_rate: float) -> None:
    env = gym.make(DRIVE_ID, control_rate=control_rate)
    scans = []
    env.unwrapped.sim.subscribe("/scan", scans.append)
    env.reset(seed=2)
    for action in actions(12, seed=3, low=(0.3, -1.0)):
        obs, *_ = env.step(action)
        latest = scans[-1]
        stamp_ns = latest.header.stamp.sec * 10**9 + latest.header.stamp.nanosec
        assert 0 <= env.unwrapped.sim.time_ns - stamp_ns < 25_000_000  # the lidar's 40 Hz
        np.testing.assert_array_equal(obs["scan"], np.minimum(latest.ranges, 10.0))
    env.close()


@pytest.mark.parametrize("world", world_names())
def test_every_builtin_world_drives(world: str) -> None:
    env = gym.make(DRIVE_ID, world=world)
    obs, _ = env.reset(seed=0)
    for _ in range(10):
        obs, reward, terminated, _, info = env.step(np.array([0.5, 0.0], np.float32))
    assert env.observation_space.contains(obs) and not terminated and info["crash"] is None
    assert reward > 0  # forward along walker's centerline, or along the heading elsewhere
    env.close()


def test_reset_options_spawn_and_world() -> None:
    env = gym.make(DRIVE_ID, world="empty")
    env.reset(seed=0, options={"spawn": (3.0, -2.0, math.pi / 2)})
    x, y, yaw = env.unwrapped.agent.pose()
    assert (x, y, yaw) == pytest.approx((3.0, -2.0, math.pi / 2), abs=1e-9)
    obs, _ = env.reset(seed=0, options={"world": "walker"})
    assert env.unwrapped.sim.world.name == "walker"
    assert obs["scan"].min() < 3.0  # walls now: the corridor is 2.25 m wide
    env.close()


def test_driving_forward_makes_progress_along_the_walker_centerline_then_crashes() -> None:
    env = gym.make(DRIVE_ID)  # walker: the car faces +x along the first straight, 6 m from the corner wall
    env.reset(seed=0)
    rewards, progress = [], 0.0
    for _ in range(400):
        obs, reward, terminated, truncated, info = env.step(FORWARD)
        rewards.append(reward)
        assert not truncated
        if terminated:
            break
        progress += info["progress"]
    assert terminated and not truncated and info["crash"] == "wall"
    assert rewards[-1] == pytest.approx(info["progress"] - CRASH_PENALTY)
    assert all(r >= -1e-6 for r in rewards[:-1]) and sum(rewards[:20]) > 0.5
    # the corridor's corner lies on the centerline at x = 7.2: progress is the x gained up to there
    x, _, _ = env.unwrapped.agent.pose()
    assert progress == pytest.approx(min(x, 7.2) - 0.0, abs=0.1)
    assert obs["speed"].shape == (1,)
    env.close()


def test_speed_and_steering_observations_follow_the_command() -> None:
    env = gym.make(DRIVE_ID, world="empty", action="raw", sensor_noise=False)
    env.reset(seed=0)
    for _ in range(40):  # 2 s
        obs, *_ = env.step(np.array([1.0, 0.2], np.float32))
    assert obs["speed"][0] == pytest.approx(1.0, abs=0.05)
    assert obs["steering"][0] == pytest.approx(0.2, abs=0.01)
    assert (obs["scan"] == 10.0).all()  # nothing in range: +inf reads as range_max
    env.close()


def test_distance_driven_without_a_centerline_and_a_track_csv_centerline(tmp_path: Path) -> None:
    env = gym.make(DRIVE_ID, world="empty")
    env.reset(seed=0, options={"spawn": (0.0, 0.0, math.pi / 4)})
    total = sum(env.step(FORWARD)[1] for _ in range(30))
    x, y, _ = env.unwrapped.agent.pose()
    assert total == pytest.approx(math.hypot(x, y), rel=0.02)
    env.close()
    radius = 6.0
    angles = np.linspace(0.0, 2 * math.pi, 120, endpoint=False)
    track = tmp_path / "circle.csv"
    track.write_text(
        "x,y,w_right,w_left\n"
        + "".join(f"{radius * math.cos(a):.9f},{radius * math.sin(a):.9f},1.0,1.0\n" for a in angles)
    )
    env = gym.make(DRIVE_ID, world=track, action="raw")
    env.reset(seed=0)
    steer = math.atan(0.325 / radius)
    total = sum(env.step(np.array([1.5, steer], np.float32))[1] for _ in range(60))
    x, y, _ = env.unwrapped.agent.pose()
    arc = radius * math.atan2(y, x)  # the centerline starts at (R, 0) and runs anticlockwise
    assert total == pytest.approx(arc, abs=0.1) and total > 3.0
    env.close()


def test_centerline_projection_wraps_round_a_loop() -> None:
    square = Centerline(np.array([[0, 0], [4, 0], [4, 4], [0, 4]], float), closed=True)
    assert square.length == 16.0
    assert square.project(2.0, -0.3) == pytest.approx(2.0)
    assert square.wrap(15.0 - 1.0) == pytest.approx(-2.0)  # 14 m ahead is 2 m behind on a 16 m loop
    assert square.project(0.2, 0.5, near=15.5) == pytest.approx(15.5)  # the last side, not the first


@pytest.mark.parametrize("mode", ["sync", "async"])
def test_vector_envs_step(mode: str) -> None:
    vec = gym.make_vec(DRIVE_ID, num_envs=4, vectorization_mode=mode)
    try:
        obs, _ = vec.reset(seed=[0, 1, 2, 3])
        assert obs["scan"].shape == (4, 1081)
        for _ in range(5):
            obs, rewards, terminated, truncated, _ = vec.step(np.tile(FORWARD, (4, 1)))
        assert rewards.shape == (4,) and (rewards > 0).all() and not terminated.any() and not truncated.any()
        assert not np.array_equal(obs["scan"][0], obs["scan"][1])  # seeds differ: noise differs
        np.testing.assert_allclose(obs["speed"][0], obs["speed"][1], atol=1e-9)  # the physics does not
    finally:
        vec.close()


@needs_gl
def test_rgb_array_render_is_a_chase_camera_frame() -> None:
    env = gym.make(DRIVE_ID, render_mode="rgb_array")
    env.reset(seed=0)
    env.step(FORWARD)
    frame = env.render()
    assert frame.shape == (480, 640, 3) and frame.dtype == np.uint8 and frame.std() > 5
    context = env.unwrapped._view._chase.target.context
    assert context.shadowSize > 0 and context.shadowFBO > 0  # drawn with MuJoCo's flags (shadows on): its map kept
    env.close()


@needs_gl
def test_camera_env_observes_the_image() -> None:
    env = gym.make(DRIVE_CAMERA_ID)
    obs, _ = env.reset(seed=0)
    assert obs["image"].shape == (480, 640, 3) and obs["image"].dtype == np.uint8
    assert env.observation_space.contains(obs)
    env.close()


def test_time_limit_truncates() -> None:
    env = gym.make(DRIVE_ID, world="empty", time_limit=0.5)
    env.reset(seed=0)
    ends = [env.step(FORWARD)[3] for _ in range(10)]
    assert ends == [False] * 9 + [True]  # 10 steps of 50 ms
    env.close()
