"""Stable-Baselines3 on the native batch (envs/sb3.py): the adapter gives what SB3's own DummyVecEnv of N DriveEnvs
gives (observations, rewards, dones, infos with terminal_observation and TimeLimit.truncated), SB3's VecEnv wrappers
step it, and PPO learns on it. Needs the [rl] extra (skipped without it)."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

pytest.importorskip("stable_baselines3")
pytest.importorskip("torch")

from stable_baselines3 import PPO
from stable_baselines3.common.vec_env import DummyVecEnv, VecMonitor, VecNormalize

from racecar_sim.core.errors import ConfigError
from racecar_sim.envs import DRIVE_ID
from racecar_sim.envs.batch import DriveBatch
from racecar_sim.envs.sb3 import PooledLidar, SB3VecEnv
from racecar_sim.envs.spaces import pooled_features

N, STEPS = 3, 30


def same(a, b) -> bool:
    """Equal observations (dicts of arrays or arrays), infos or values, exactly."""
    if isinstance(a, dict):
        return isinstance(b, dict) and a.keys() == b.keys() and all(same(a[k], b[k]) for k in a)
    return bool(np.array_equal(np.asarray(a), np.asarray(b)))


def test_the_adapter_gives_what_dummy_vec_env_of_drive_envs_gives():
    """World 0 crashes (terminated), world 1 reaches the step limit (truncated); 50 steps of the adapter on the
    batch against SB3's DummyVecEnv of DriveEnvs with the same seeds: everything equal, reset infos too."""
    dummy = DummyVecEnv([lambda: gym.make(DRIVE_ID, max_episode_steps=STEPS) for _ in range(N)])
    adapter = SB3VecEnv(DriveBatch(N, world="walker", max_episode_steps=STEPS))
    try:
        assert adapter.num_envs == dummy.num_envs and adapter.action_space == dummy.action_space
        assert adapter.observation_space == dummy.observation_space
        for venv in (dummy, adapter):
            venv.seed(21)
        assert same(dummy.reset(), adapter.reset())
        assert all(same(a, b) for a, b in zip(dummy.reset_infos, adapter.reset_infos))
        rng = np.random.default_rng(1)
        ended = {"terminal": 0, "time limit": 0}
        for k in range(50):
            actions = np.array([[1.0, 1.0], [0.6, 0.0], rng.uniform(-1, 1, 2)], np.float32)
            (obs_a, rew_a, done_a, infos_a), (obs_b, rew_b, done_b, infos_b) = (
                dummy.step(actions),
                adapter.step(actions),
            )
            assert same(obs_a, obs_b) and same(rew_a, rew_b) and same(done_a, done_b), f"step {k}"
            assert rew_b.dtype == np.float32 and done_b.dtype == bool
            for i, (info_a, info_b) in enumerate(zip(infos_a, infos_b)):
                assert same(info_a, info_b), f"step {k} world {i}: {info_a} != {info_b}"
                if "terminal_observation" in info_b:
                    ended["time limit" if info_b["TimeLimit.truncated"] else "terminal"] += 1
            assert all(same(a, b) for a, b in zip(dummy.reset_infos, adapter.reset_infos))
        assert ended["terminal"] >= 2 and ended["time limit"] >= 1
    finally:
        dummy.close()
        adapter.close()


def test_sb3_wrappers_step_the_batch():
    """VecNormalize over VecMonitor over the adapter: the monitor's episode return is the sum of the episode's
    rewards, its length the steps it took; the normaliser keeps running statistics of the dict observation."""
    monitor = VecMonitor(SB3VecEnv(DriveBatch(2, world="walker", max_episode_steps=10, seeds=0)))
    venv = VecNormalize(monitor, norm_obs_keys=["scan", "speed", "steering"])
    try:
        obs = venv.reset()
        assert obs["scan"].shape == (2, 1081) and obs["speed"].shape == (2, 1)
        totals, episodes = np.zeros(2), []
        for _ in range(25):
            _, _, dones, infos = venv.step(np.array([[0.8, 0.1], [0.5, -0.1]], np.float32))
            totals += venv.get_original_reward()
            for i in np.flatnonzero(dones):
                episodes.append(infos[i]["episode"])
                assert infos[i]["episode"]["r"] == pytest.approx(totals[i], abs=1e-5)
                assert infos[i]["episode"]["l"] == 10 and infos[i]["TimeLimit.truncated"]
                totals[i] = 0.0
        assert len(episodes) == 4 and all(e["r"] > 0 for e in episodes)  # driving forward gains progress
        assert venv.obs_rms["speed"].count > 25
    finally:
        venv.close()


def test_ppo_multi_input_policy_trains_on_the_batch():
    adapter = SB3VecEnv(DriveBatch(4, world="walker", max_episode_steps=12, seeds=0))
    try:
        model = PPO("MultiInputPolicy", adapter, n_steps=16, batch_size=32, seed=0, device="cpu")
        model.learn(64)
        assert model.num_timesteps >= 64
        action, _ = model.predict(adapter.reset(), deterministic=True)
        assert action.shape == (4, 2) and np.isfinite(action).all()
    finally:
        adapter.close()


def test_pooled_lidar_pools_each_sector():
    batch = DriveBatch(2, world="walker", seeds=3)
    venv = PooledLidar(SB3VecEnv(batch), sectors=27)
    try:
        features = venv.reset()
        raw = batch.observation()
        assert features.shape == (2, 29) and venv.observation_space.contains(features[0])
        for w in range(2):  # each sector is the nearest return of its beams, over the 10 m range limit
            beams = np.array_split(raw["scan"][w], 27)
            assert features[w, :27] == pytest.approx([b.min() / 10.0 for b in beams], abs=1e-6)
            assert features[w, 27] == pytest.approx(raw["speed"][w, 0] / 2.0)
            assert features[w, 28] == pytest.approx(raw["steering"][w, 0] / 0.34, abs=1e-6)
            single = pooled_features({k: v[w] for k, v in raw.items()}, 27, 10.0)
            np.testing.assert_array_equal(single, features[w])
    finally:
        venv.close()


def test_the_adapter_refuses_a_next_step_vector_env():
    envs = gym.make_vec(DRIVE_ID, num_envs=2, vectorization_mode="sync")  # Gymnasium's default: NEXT_STEP
    try:
        with pytest.raises(ConfigError, match="SAME_STEP"):
            SB3VecEnv(envs)
    finally:
        envs.close()
