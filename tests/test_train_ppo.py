"""examples/train_ppo.py: a short Stable-Baselines3 PPO run on the native batch of lidar envs completes (the example
shows the learning curve; this only checks that training runs end to end, shows its progress and leaves its files).
Needs the [rl] extra (skipped without it)."""

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


def test_the_training_env_is_the_batch_with_pooled_features(train_ppo):
    venv = train_ppo.make_env(episode_seconds=2.0, sectors=27, n_envs=3, seed=1)
    try:
        batch = venv.unwrapped.env  # VecMonitor -> PooledLidar -> SB3VecEnv -> DriveBatch
        assert type(batch).__name__ == "DriveBatch" and batch.num_envs == 3 and batch.time_limit_ns == 2_000_000_000
        features = venv.reset()
        raw = batch.observation()
        assert features.shape == (3, 29) and list(batch.seeds) == [1, 2, 3]
        # each sector is the nearest return in its beams, over the 10 m range limit
        beams = np.array_split(raw["scan"][2], 27)
        assert features[2, :27] == pytest.approx([b.min() / 10.0 for b in beams], abs=1e-6)
        assert features[2, 27] == pytest.approx(raw["speed"][2, 0] / 2.0, abs=1e-6)
    finally:
        venv.close()


def test_short_ppo_run_completes(train_ppo, tmp_path, capsys):
    # 4 worlds x 128 steps per update, 2 s episodes; the progress bar on
    training = train_ppo.train(2048, n_envs=4, n_steps=128, batch_size=64, episode_seconds=2.0, progress=True)
    assert training.model.num_timesteps >= 2048
    assert len(training.returns) >= 2048 // 40 // 2  # every episode ends within 40 steps (2 s at 20 Hz)
    assert all(length <= 40 for length in training.lengths)
    assert all(np.isfinite(training.returns))
    assert training.ended_at == sorted(training.ended_at) and training.ended_at[-1] <= 2048
    action, _ = training.model.predict(np.zeros(29, np.float32), deterministic=True)
    assert action.shape == (2,)
    bar = capsys.readouterr().err
    assert "2048/2048" in bar and "mean return (last 20)" in bar  # the bar, with the running mean of 20 episodes

    train_ppo.write_episodes(training, tmp_path / "episodes.csv")
    train_ppo.plot_learning_curve(training, tmp_path / "learning_curve.png", "test")
    with open(tmp_path / "episodes.csv", newline="") as f:
        assert len(list(csv.DictReader(f))) == len(training.returns)
    assert (tmp_path / "learning_curve.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_main_writes_the_three_files(train_ppo, tmp_path, capsys):
    out = tmp_path / "ppo"
    assert train_ppo.main(["--timesteps", "256", "--envs", "2", "--episode-seconds", "1", "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    for name in ("learning_curve.png", "episodes.csv", "policy.zip"):
        assert (out / name).stat().st_size > 0 and f"wrote {out / name}" in printed
