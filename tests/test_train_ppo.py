"""examples/train_ppo.py: a short Stable-Baselines3 PPO run on the lidar env completes (the example shows the
learning curve; this only checks that training runs end to end and leaves its files)."""

from __future__ import annotations

import csv
import importlib.util
import sys
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("stable_baselines3")
pytest.importorskip("torch")

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "train_ppo.py"


@pytest.fixture(scope="module")
def train_ppo():
    spec = importlib.util.spec_from_file_location("train_ppo", EXAMPLE)
    module = importlib.util.module_from_spec(spec)
    sys.modules["train_ppo"] = module  # its dataclass looks its module up while being defined
    try:
        spec.loader.exec_module(module)
        yield module
    finally:
        sys.modules.pop("train_ppo", None)


def test_lidar_features_pool_the_scan(train_ppo):
    env = train_ppo.make_env(episode_seconds=2.0, sectors=27)
    try:
        features, _ = env.reset(seed=1)
        raw = env.unwrapped.agent.observation()
        assert features.shape == (29,) and env.observation_space.contains(features)
        # each sector is the nearest return in its beams, over the 10 m range limit
        beams = np.array_split(raw["scan"], 27)
        assert features[:27] == pytest.approx([b.min() / 10.0 for b in beams], abs=1e-6)
        assert features[27] == pytest.approx(raw["speed"][0] / 2.0, abs=1e-6)
    finally:
        env.close()


def test_short_ppo_run_completes(train_ppo, tmp_path):
    # one process: the test must not depend on forking; 2 envs x 256 steps per update, 2 s episodes
    training = train_ppo.train(2048, n_envs=2, n_steps=256, batch_size=64, episode_seconds=2.0, subprocess=False)
    assert training.model.num_timesteps >= 2048
    assert len(training.returns) >= 2048 // 40 // 2  # every episode ends within 40 steps (2 s at 20 Hz)
    assert all(length <= 40 for length in training.lengths)
    assert all(np.isfinite(training.returns))
    action, _ = training.model.predict(np.zeros(29, np.float32), deterministic=True)
    assert action.shape == (2,)

    train_ppo.write_episodes(training, tmp_path / "episodes.csv")
    train_ppo.plot_learning_curve(training, tmp_path / "learning_curve.png", "test")
    with open(tmp_path / "episodes.csv", newline="") as f:
        assert len(list(csv.DictReader(f))) == len(training.returns)
    assert (tmp_path / "learning_curve.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
