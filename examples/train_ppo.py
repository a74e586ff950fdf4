"""Train a driving policy with Stable-Baselines3 PPO on the lidar env, on CPU, and plot its learning curve.

    pip install -e ".[rl]"          # stable-baselines3 and torch==2.13.0 (the CPU build)
    python examples/train_ppo.py    # ~3.5 min on 2 cores: runs/ppo/learning_curve.png, episodes.csv, policy.zip
    python examples/train_ppo.py --timesteps 300000 --out runs/ppo-long

The env is racecar_sim/Drive-v0 on walker: the reward is the metres of progress along walker's centerline, minus
10 on a crash into a wall, which ends the episode; an episode is truncated after --episode-seconds of sim time.
The agent's command goes through the navigation mux input at 20 Hz, as any driver's would. The policy sees the
scan min-pooled into --sectors sectors (the nearest wall in each, scaled to [0, 1]), the speed and the steering
angle (LidarFeatures below): 1081 raw beams would train far slower on a CPU.
"""

from __future__ import annotations

import argparse
import csv
import time
from dataclasses import dataclass
from pathlib import Path

import gymnasium as gym
import numpy as np

import racecar_sim.envs  # noqa: F401  (registers racecar_sim/Drive-v0)

ENV_ID = "racecar_sim/Drive-v0"
DEFAULT_TIMESTEPS = 120_000  # ~3.5 minutes on a 2-core CPU (~550 steps/s with PPO's updates)
SECTORS = 27  # 10 degrees each over the Hokuyo's 270


class LidarFeatures(gym.ObservationWrapper):
    """The Drive env's observation as one small vector: the scan min-pooled into `sectors` equal sectors and
    divided by the range limit (1 = nothing within range), the speed over max_speed, the steering angle over
    max_steering."""

    def __init__(self, env: gym.Env, sectors: int = SECTORS) -> None:
        super().__init__(env)
        scan = env.observation_space["scan"]
        self.range_max = float(scan.high.max())
        self.sectors = sectors
        sizes = [len(part) for part in np.array_split(np.arange(scan.shape[0]), sectors)]
        self.starts = np.cumsum([0, *sizes[:-1]])  # sectors as np.array_split cuts them
        drive = env.unwrapped.limits
        self.scale = np.array([drive.max_speed, drive.max_steering], np.float32)
        self.observation_space = gym.spaces.Box(-np.inf, np.inf, (sectors + 2,), np.float32)

    def observation(self, observation: dict[str, np.ndarray]) -> np.ndarray:
        near = np.minimum.reduceat(observation["scan"], self.starts) / self.range_max
        motion = np.concatenate([observation["speed"], observation["steering"]]) / self.scale
        return np.concatenate([near, motion]).astype(np.float32)


def make_env(world: str = "walker", episode_seconds: float = 30.0, sectors: int = SECTORS) -> gym.Env:
    """The lidar env on `world`, truncated after `episode_seconds`, with LidarFeatures on top."""
    return LidarFeatures(gym.make(ENV_ID, world=world, time_limit=episode_seconds), sectors)


@dataclass
class Training:
    """What a training run left: the episodes' returns and lengths, the timestep each ended at, the model."""

    returns: list[float]
    lengths: list[int]
    ended_at: list[int]
    seconds: float
    model: object

    def mean_return(self, first: bool, fraction: float = 0.1) -> float:
        """The mean return of the first (or last) `fraction` of the episodes."""
        n = max(1, round(len(self.returns) * fraction))
        part = self.returns[:n] if first else self.returns[-n:]
        return float(np.mean(part))


def train(
    timesteps: int = DEFAULT_TIMESTEPS,
    *,
    world: str = "walker",
    episode_seconds: float = 30.0,
    n_envs: int = 2,
    n_steps: int = 512,
    batch_size: int = 128,
    seed: int = 0,
    sectors: int = SECTORS,
    subprocess: bool = True,
    verbose: int = 0,
) -> Training:
    """PPO for `timesteps` env steps over `n_envs` envs (each in its own process with `subprocess`), collecting
    `n_steps` per env between updates; returns every finished episode's return."""
    import torch
    from stable_baselines3 import PPO
    from stable_baselines3.common.callbacks import BaseCallback
    from stable_baselines3.common.env_util import make_vec_env
    from stable_baselines3.common.vec_env import DummyVecEnv, SubprocVecEnv

    torch.set_num_threads(1)  # the envs take the other cores; small MLPs gain nothing from more threads

    class EpisodeLog(BaseCallback):
        """Every finished episode's return and length, from the Monitor wrapper's info["episode"]."""

        def __init__(self) -> None:
            super().__init__()
            self.returns: list[float] = []
            self.lengths: list[int] = []
            self.ended_at: list[int] = []

        def _on_step(self) -> bool:
            for info in self.locals["infos"]:
                if "episode" in info:
                    self.returns.append(float(info["episode"]["r"]))
                    self.lengths.append(int(info["episode"]["l"]))
                    self.ended_at.append(self.num_timesteps)
            return True

    vec_env = make_vec_env(
        make_env,
        n_envs=n_envs,
        seed=seed,
        env_kwargs={"world": world, "episode_seconds": episode_seconds, "sectors": sectors},
        vec_env_cls=SubprocVecEnv if subprocess and n_envs > 1 else DummyVecEnv,
    )
    try:
        model = PPO(
            "MlpPolicy",
            vec_env,
            n_steps=n_steps,
            batch_size=batch_size,
            n_epochs=10,
            gamma=0.99,
            gae_lambda=0.95,
            learning_rate=3e-4,
            ent_coef=0.0,
            clip_range=0.2,
            seed=seed,
            verbose=verbose,
            policy_kwargs={"net_arch": [64, 64]},
            device="cpu",
        )
        log = EpisodeLog()
        start = time.perf_counter()
        model.learn(total_timesteps=timesteps, callback=log)
        seconds = time.perf_counter() - start
    finally:
        vec_env.close()
    return Training(log.returns, log.lengths, log.ended_at, seconds, model)


def write_episodes(training: Training, path: Path) -> None:
    """episodes.csv: episode, timestep it ended at, return, length in steps."""
    with open(path, "w", newline="") as f:
        writer = csv.writer(f)
        writer.writerow(["episode", "timestep", "return", "length"])
        for k, row in enumerate(zip(training.ended_at, training.returns, training.lengths)):
            writer.writerow([k, *row])


def plot_learning_curve(training: Training, path: Path, title: str) -> None:
    """learning_curve.png: each episode's return against the timestep it ended at, and a moving mean."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    steps, returns = np.array(training.ended_at), np.array(training.returns)
    window = max(1, len(returns) // 20)
    mean = np.convolve(returns, np.ones(window) / window, mode="valid")
    fig, ax = plt.subplots(figsize=(8, 4.5), dpi=120)
    ax.plot(steps, returns, ".", ms=3, alpha=0.35, color="tab:blue", label="episode return")
    ax.plot(steps[window - 1 :], mean, color="tab:red", lw=2, label=f"mean of {window} episodes")
    ax.set_xlabel("env steps (20 Hz control)")
    ax.set_ylabel("return (m of progress, -10 per crash)")
    ax.set_title(title)
    ax.grid(alpha=0.3)
    ax.legend(loc="upper left")
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument(
        "--timesteps",
        type=int,
        default=DEFAULT_TIMESTEPS,
        help=f"env steps to train for (default {DEFAULT_TIMESTEPS}: a few minutes on CPU)",
    )
    p.add_argument("--world", default="walker", help="a world with a centerline (default walker)")
    p.add_argument("--episode-seconds", type=float, default=30.0, help="sim seconds per episode (default 30)")
    p.add_argument("--envs", type=int, default=2, help="envs stepped in parallel processes (default 2)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--out", default="runs/ppo", help="folder for the curve, the episodes and the policy")
    args = p.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    training = train(
        args.timesteps,
        world=args.world,
        episode_seconds=args.episode_seconds,
        n_envs=args.envs,
        seed=args.seed,
        verbose=0,
    )
    training.model.save(out / "policy.zip")
    write_episodes(training, out / "episodes.csv")
    title = f"PPO on {ENV_ID} ({args.world}): {args.timesteps} steps, {training.seconds / 60:.1f} min on CPU"
    plot_learning_curve(training, out / "learning_curve.png", title)
    print(
        f"{len(training.returns)} episodes in {training.seconds:.0f} s "
        f"({args.timesteps / training.seconds:.0f} steps/s)"
    )
    if training.returns:
        print(f"mean return, first 10% of episodes: {training.mean_return(first=True):.2f}")
        print(f"mean return, last 10% of episodes:  {training.mean_return(first=False):.2f}")
    for name in ("learning_curve.png", "episodes.csv", "policy.zip"):
        print(f"wrote {out / name}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
