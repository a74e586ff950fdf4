"""A trained policy drives: the PolicyDriver node (envs/policy.py) drives a Simulator's car exactly as DriveEnv stepped
with the same policy and seed, and `racecar-sim play POLICY.zip` writes the run folder `racecar-sim run` writes, its
recorded commands being the policy's actions. Without Stable-Baselines3, play is one line and exit code 2."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from rosbags.highlevel import AnyReader

from conftest import GL_MISSING
from racecar_sim import Simulator
from racecar_sim.cli.main import main as cli_main
from racecar_sim.core.errors import ConfigError
from racecar_sim.envs.drive import DriveEnv
from racecar_sim.envs.policy import attach_policy
from racecar_sim.envs.spaces import pooled_features, to_command

NAVIGATION = "/vesc/ackermann_cmd_mux/input/navigation"


def gap_policy(obs: dict[str, np.ndarray]) -> np.ndarray:
    """A small hand-made policy of DriveEnv's observation: steer toward the most open of 9 sectors, slower in turns."""
    near = pooled_features(obs, 9, 10.0)[:9]
    steer = (int(np.argmax(near)) - 4) / 4.0
    return np.array([0.6 - 0.3 * abs(steer), steer], np.float32)


@pytest.mark.parametrize("rate", [20.0, 30.0])
def test_the_policy_driver_drives_as_drive_env(rate: float) -> None:
    """4 s on walker, seed 3: the node's car ends in DriveEnv's state bit for bit (the same observations, actions and
    command times); at 30 Hz the control steps fall between scans."""
    env = DriveEnv(world="walker", control_rate=rate)
    obs, _ = env.reset(seed=3)
    steps = int(4.0 * rate)
    for _ in range(steps):
        obs, *_ = env.step(gap_policy(obs))
    with Simulator(world="walker", seed=3, camera=False) as sim:
        node = attach_policy(sim, sim.car, gap_policy, rate=rate)
        sim.run_until(steps / rate)
        assert node.actions == steps + 1  # at t = 0 and every period up to and including the end
        np.testing.assert_array_equal(sim.data.qpos, env.sim.data.qpos)
        np.testing.assert_array_equal(sim.data.qvel, env.sim.data.qvel)
        assert env.sim.data.qpos[0] > 1.0  # it drove
    env.close()


def test_the_policy_driver_starts_again_after_a_reset() -> None:
    with Simulator(world="walker", seed=3, camera=False) as sim:
        attach_policy(sim, sim.car, gap_policy)
        sim.run_until(1.0)
        first = sim.data.qpos.copy()
        sim.reset(3)
        sim.run_until(1.0)
        np.testing.assert_array_equal(sim.data.qpos, first)


def test_policy_driver_refuses_what_it_cannot_drive() -> None:
    with Simulator(world="empty", camera=False, lidar=False) as sim:
        with pytest.raises(ConfigError, match="observes the lidar"):
            attach_policy(sim, sim.car, gap_policy)
    with Simulator(world="empty", camera=False) as sim:
        with pytest.raises(ConfigError, match="faster than 5 Hz"):
            attach_policy(sim, sim.car, gap_policy, rate=4.0)


def test_play_without_stable_baselines3_is_one_line(tmp_path: Path) -> None:
    policy = tmp_path / "policy.zip"
    policy.write_bytes(b"PK")
    code = (
        "import sys; sys.modules['stable_baselines3'] = None\n"  # as if it were not installed: import fails
        "from racecar_sim.cli.main import main\n"
        f"sys.exit(main(['play', {str(policy)!r}, '--no-camera']))\n"
    )
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert result.returncode == 2
    assert result.stderr.strip().count("\n") == 0 and "[rl]" in result.stderr and "pip install" in result.stderr
    assert result.stdout == ""


def test_play_refuses_driver_options_and_a_missing_policy(tmp_path: Path, capsys) -> None:
    assert cli_main(["play", str(tmp_path / "none.zip")]) == 2
    assert "no such file" in capsys.readouterr().err
    (tmp_path / "p.zip").write_bytes(b"PK")
    assert cli_main(["play", str(tmp_path / "p.zip"), "--speed", "1"]) == 2
    assert "--speed does not apply to play" in capsys.readouterr().err


def test_play_drives_a_trained_policy_and_writes_the_run_folder(tmp_path: Path, capsys) -> None:
    """A PPO trained briefly on the batch with pooled lidar features (as examples/train_ppo.py trains) drives walker
    for 3 s: run.mcap, summary.png (and camera.mp4 with OpenGL), and the recorded navigation commands are the
    model's deterministic actions on DriveEnv with the same seed, converted as DriveEnv converts them."""
    pytest.importorskip("stable_baselines3")
    pytest.importorskip("torch")
    from stable_baselines3 import PPO

    from racecar_sim.envs.batch import DriveBatch
    from racecar_sim.envs.sb3 import PooledLidar, SB3VecEnv

    venv = PooledLidar(SB3VecEnv(DriveBatch(2, world="walker", max_episode_steps=20, seeds=0)), sectors=27)
    model = PPO("MlpPolicy", venv, n_steps=32, batch_size=32, seed=0, device="cpu")
    model.learn(64)
    venv.close()
    model.save(tmp_path / "policy.zip")

    out = tmp_path / "run"
    camera = [] if not GL_MISSING else ["--no-camera"]
    args = ["play", str(tmp_path / "policy.zip"), "--world", "walker", "--duration", "3", "--seed", "5"]
    assert cli_main([*args, "--out", str(out), *camera]) == 0
    printed = capsys.readouterr().out
    assert "driver policy policy.zip" in printed and f"wrote            {out / 'run.mcap'}" in printed
    assert (out / "summary.png").read_bytes()[:4] == b"\x89PNG"
    assert (out / "camera.mp4").exists() == (not GL_MISSING)

    with AnyReader([out / "run.mcap"]) as reader:
        connections = [c for c in reader.connections if c.topic == NAVIGATION]
        recorded = [
            (reader.deserialize(raw, c.msgtype).drive.speed, reader.deserialize(raw, c.msgtype).drive.steering_angle)
            for c, _, raw in reader.messages(connections=connections)
        ]
    env = DriveEnv(world="walker")
    obs, _ = env.reset(seed=5)
    expected = []
    for _ in range(61):  # t = 0, 0.05, ..., 3.0
        action, _ = model.predict(pooled_features(obs, 27, 10.0), deterministic=True)
        expected.append(to_command(action))
        obs, *_ = env.step(action)
    env.close()
    assert len(recorded) == 61
    np.testing.assert_allclose(np.array(recorded), np.array(expected), rtol=0, atol=1e-6)
