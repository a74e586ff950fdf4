"""The native batch (envs/batch.py) against single DriveEnvs (same seeds and actions: same state and observations), and
its parts against independent references: the batched cast of tilted scans against MuJoCo's rays."""

from __future__ import annotations

import copy

import mujoco
import numpy as np
import pytest

from racecar_sim.core.errors import ConfigError
from racecar_sim.envs.batch import DriveBatch
from racecar_sim.envs.drive import DriveEnv
from racecar_sim.physics import COLLISION_GROUP
from racecar_sim.sensors.raycast import RayCaster
from racecar_sim.sensors.raycast.batch import BatchFrames

N, STEPS = 8, 40


def test_batch_of_8_matches_8_single_envs():
    """Bit for bit on qpos/qvel (required: 1e-9), and on every observation entry and reward, for random actions."""
    actions = np.random.default_rng(5).uniform(-1, 1, size=(STEPS, N, 2))
    batch = DriveBatch(N, world="walker", seeds=list(range(100, 100 + N)), max_episode_steps=None)
    first, _ = batch.reset()
    history = [batch.step(actions[k]) for k in range(STEPS)]
    for w in range(N):
        env = DriveEnv(world="walker")
        obs, _ = env.reset(seed=100 + w)
        np.testing.assert_array_equal(obs["scan"], first["scan"][w])
        for k in range(STEPS):
            obs, reward, terminated, _, _ = env.step(actions[k, w])
            b_obs, b_reward, b_terminated, _, _ = history[k]
            for key in obs:
                np.testing.assert_array_equal(obs[key], b_obs[key][w], err_msg=f"world {w} step {k} {key}")
            assert reward == b_reward[w] and terminated == b_terminated[w]
        np.testing.assert_allclose(batch.qpos[w], env.sim.data.qpos, rtol=0, atol=1e-9)
        np.testing.assert_allclose(batch.qvel[w], env.sim.data.qvel, rtol=0, atol=1e-9)
        env.close()
    batch.close()


def test_same_step_auto_reset():
    """A world that reaches the step limit is reset in that step: final_obs holds its last observation, the
    returned one is its new episode's first (at the spawn pose, at rest), and the other worlds go on."""
    batch = DriveBatch(2, world="empty", seeds=[1, 2], max_episode_steps=3)
    batch.reset()
    batch.steps[1] = -2  # world 1's episode limit comes two steps later
    forward = np.array([[1.0, 0.0], [1.0, 0.0]])
    for _ in range(2):
        obs, _, terminated, truncated, infos = batch.step(forward)
        assert not truncated.any() and "final_obs" not in infos
    obs, _, terminated, truncated, infos = batch.step(forward)
    assert list(truncated) == [True, False] and not terminated.any()
    assert list(infos["_final_obs"]) == [True, False] and list(infos["_final_info"]) == [True, False]
    assert infos["final_obs"][0]["speed"][0] > 0.1 and infos["final_obs"][1] is None  # the last observation, moving
    assert infos["final_info"]["time"][0] == pytest.approx(0.15)  # the last step's info: 3 steps of 50 ms
    assert infos["time"][0] == 0.0 and infos["time"][1] == pytest.approx(0.15)  # world 0's own entry: its reset's
    assert obs["speed"][0, 0] == 0.0 and batch.steps[0] == 0 and batch.time_ns[0] == 0
    assert obs["speed"][1, 0] > 0.1 and batch.steps[1] == 1
    np.testing.assert_array_equal(batch.qpos[0], batch.template.data.qpos)  # back at the spawn state
    batch.close()


def test_reset_world_goes_on_as_a_fresh_one():
    """The worlds share their threads' MjData: a world reset mid-run holds nothing of its last episode (time, warm
    start, velocities): it steps on exactly as a new batch's world does, and another world is not disturbed."""
    rng = np.random.default_rng(3)
    before, after = rng.uniform(-1, 1, (4, 2, 2)), rng.uniform(-1, 1, (6, 2, 2))
    batch = DriveBatch(2, world="walker", seeds=[7, 8], max_episode_steps=4)
    batch.reset()
    batch.steps[1] = -100  # world 1 goes on
    for k in range(4):
        _, _, _, truncated, _ = batch.step(before[k])
    assert list(truncated) == [True, False]
    batch.max_episode_steps = None
    fresh = DriveBatch(1, world="walker", seeds=[7], max_episode_steps=None)
    fresh.reset()
    for k in range(6):
        batch.step(after[k])
        fresh.step(after[k, :1])
    mine, new = batch.world_data(0), fresh.world_data(0)
    for field in ("qpos", "qvel", "qacc_warmstart", "time"):
        np.testing.assert_array_equal(getattr(mine, field), getattr(new, field), err_msg=field)
    assert batch.time_ns[0] == fresh.time_ns[0] and batch.time_ns[1] == 10 * batch.period_ns
    assert np.abs(batch.qvel[1]).max() > 0.1  # world 1 drove on through world 0's reset
    batch.close()
    fresh.close()


def test_warp_device_without_gpu_is_one_line_error():
    with pytest.raises(ConfigError) as err:
        DriveBatch(2, device="warp")
    assert "\n" not in str(err.value) and "gpu" in str(err.value).lower()


def test_batched_cast_of_tilted_scans_matches_mujoco_rays():
    """A pitched or rolled car's scan reaches the floor box's top and passes over or under the walls' edges: the
    batched cast (sides checked against the heights a box spans, top faces) gives MuJoCo's own 3-D ray casts."""
    tilts = [
        (0.0, 0.0),
        (1.0, 0.0),
        (2.0, 0.0),
        (-2.0, 0.0),
        (0.0, 3.0),
        (4.0, -1.5),
        (6.0, 0.0),
        (-15.0, 0.0),
    ]  # pitch, roll
    batch = DriveBatch(len(tilts), world="walker", seeds=0)
    lidar, root = batch.lidar, batch.root_qpos
    qpos = np.repeat(batch.template.data.qpos[None], len(tilts), axis=0)
    for k, (_pitch, _roll) in enumerate(np.radians(tilts)):
        qpos[k, root : root + 2] += [0.7 * k, 0.1 * k]
        qpos[k, root + 3 : root + 7] = [np.cos(0.15 * k), 0, 0, np.sin(0.15 * k)]
    level = lidar.true_ranges(qpos)
    for k, (pitch, roll) in enumerate(np.radians(tilts)):
        cp, sp, cr, sr = np.cos(pitch / 2), np.sin(pitch / 2), np.cos(roll / 2), np.sin(roll / 2)
        yaw = np.array([np.cos(0.15 * k), 0, 0, np.sin(0.15 * k)])
        tilt = np.array([cp * cr, cp * sr, sp * cr, -sp * sr])
        w0, x0, y0, z0 = yaw
        w1, x1, y1, z1 = tilt
        qpos[k, root + 3 : root + 7] = [
            w0 * w1 - x0 * x1 - y0 * y1 - z0 * z1,
            w0 * x1 + x0 * w1 + y0 * z1 - z0 * y1,
            w0 * y1 - x0 * z1 + y0 * w1 + z0 * x1,
            w0 * z1 + x0 * y1 - y0 * x1 + z0 * w1,
        ]
    ranges = lidar.true_ranges(qpos)
    model = copy.copy(batch.model)
    data = mujoco.MjData(model)
    caster = RayCaster(model, data, lidar.fan, batch.root_body, COLLISION_GROUP)
    origin, axes = lidar.mount.poses(qpos)  # LaserMount is checked against MuJoCo's kinematics in test_laser_mount.py
    for k in range(len(tilts)):
        data.qpos[:] = qpos[k]
        mujoco.mj_kinematics(model, data)
        reference = caster.cast(origin[k], axes[k], mode="3d")
        np.testing.assert_array_equal(np.isinf(ranges[k]), np.isinf(reference), err_msg=f"tilt {tilts[k]}")
        hit = np.isfinite(reference)
        np.testing.assert_allclose(ranges[k][hit], reference[hit], rtol=1e-12, err_msg=f"tilt {tilts[k]}")
    _, fallback = lidar.walls.cast(BatchFrames.from_poses(origin, axes, lidar.fan))
    assert len(fallback) == 0  # all answered by the batched cast, none by a RayCaster
    assert ranges[-1][0] < level[-1][0] - 0.5  # tail pitched down 15 degrees: the rear beams meet the floor's top
    batch.close()


def test_a_batch_with_tyres_matches_single_envs_with_tyres():
    """The tyre model and the rate limits run in MuJoCo's callbacks, so every world of the native batch gets them:
    a batch of f1tenth cars follows single f1tenth DriveEnvs, bit for bit (and differs from the seed's car)."""
    n, steps = 3, 30
    actions = np.random.default_rng(9).uniform(-1, 1, size=(steps, n, 2))
    batch = DriveBatch(n, world="walker", seeds=list(range(n)), max_episode_steps=None, vehicle="f1tenth")
    batch.reset()
    for k in range(steps):
        batch.step(actions[k])
    for w in range(n):
        env = DriveEnv(world="walker", vehicle="f1tenth")
        env.reset(seed=w)
        for k in range(steps):
            env.step(actions[k, w])
        np.testing.assert_allclose(batch.qpos[w], env.sim.data.qpos, rtol=0, atol=1e-9)
        env.close()
    seed = DriveEnv(world="walker")
    seed.reset(seed=0)
    for k in range(steps):
        seed.step(actions[k, 0])
    assert not np.allclose(seed.sim.data.qpos[:3], batch.qpos[0][:3], atol=1e-3)
    seed.close()
    batch.close()
