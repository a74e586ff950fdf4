"""Train a driving policy with Stable-Baselines3 PPO on the native batch of lidar envs, on CPU, and plot its
learning curve.

    pip install -e ".[rl]"          # Stable-Baselines3 and torch (see the README for a CPU-only torch)
    python examples/train_ppo.py    # a few minutes on 2 cores: runs/ppo/learning_curve.png, episodes.csv, policy.zip
    python examples/train_ppo.py --timesteps 300000 --out runs/ppo-long
    racecar-sim play runs/ppo/policy.zip --world walker   # the trained policy drives; the usual run folder

The envs are racecar_sim/Drive-v0 on walker, --envs of them stepped together by the native batch (DriveBatch: one
call steps every world, on a thread pool) and handed to PPO through racecar_sim.envs.sb3.SB3VecEnv: the reward is
the metres of progress along walker's centerline, minus 10 on a crash into a wall, which ends the episode; an
episode is truncated after --episode-seconds of sim time. The agent's command goes through the navigation mux input
at 20 Hz, as any driver's would. The policy sees the scan min-pooled into --sectors sectors (the nearest wall in
each, scaled to [0, 1]), the speed and the steering angle (envs.sb3.PooledLidar: spaces.pooled_features, which
`racecar-sim play` applies too): 1081 raw beams would train far slower on a CPU. A progress bar shows the steps done
and the mean return of the last 20 episodes.
"""

from __future__ import annotations

import argparse
import csv
import sys
import time
from collections import deque
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

ENV_ID = "racecar_sim/Drive-v0"
DEFAULT_TIMESTEPS = 120_000  # a few minutes on a 2-core CPU
DEFAULT_ENVS = 4  # worlds in the batch, 256 steps of each between updates (1024 in all); in one run each, 4 left
# walker's 8 m-in-30 s plateau at 60k steps, 8 only at 100k
SECTORS = 27  # 10 degrees each over the Hokuyo's 270
RUNNING = 20  # episodes in the progress bar's running mean


def make_env(
    world: str = "walker",
    episode_seconds: float = 30.0,
    sectors: int = SECTORS,
    n_envs: int = DEFAULT_ENVS,
    seed: int = 0,
) -> Any:
    """The batch of `n_envs` lidar envs on `world` (episodes truncated after `episode_seconds`) as an SB3 VecEnv
    whose policy input is the pooled lidar features, with VecMonitor's episode statistics in the infos. Its first
    reset seeds world i with seed + i."""
    from stable_baselines3.common.vec_env import VecMonitor

    from racecar_sim.envs.batch import DriveBatch
    from racecar_sim.envs.sb3 import PooledLidar, SB3VecEnv

    batch = DriveBatch(n_envs, world=world, time_limit=episode_seconds, seeds=seed)
    return VecMonitor(PooledLidar(SB3VecEnv(batch), sectors))


@dataclass
class Training:
    """What a training run left: the episodes' returns and lengths, the timestep each ended at, the model."""

    returns: list[float]
    lengths: list[int]
    ended_at: list[int]
    seconds: float
    model: Any

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
    n_envs: int = DEFAULT_ENVS,
    n_steps: int | None = None,
    batch_size: int = 128,
    seed: int = 0,
    sectors: int = SECTORS,
    progress: bool = True,
    verbose: int = 0,
) -> Training:
    """PPO for `timesteps` env steps over a batch of `n_envs` worlds, collecting `n_steps` per world between updates
    (default: 1024 in all); returns every finished episode's return. `progress`: a tqdm bar on stderr with the
    steps done and the running mean return."""
    import torch
    from stable_baselines3 import PPO
    from stable_baselines3.common.callbacks import BaseCallback
    from tqdm import tqdm

    torch.set_num_threads(1)  # the batch's threads take the cores; small MLPs gain nothing from more threads

    class EpisodeLog(BaseCallback):
        """Every finished episode's return and length, from VecMonitor's info["episode"]; the progress bar."""

        def __init__(self) -> None:
            super().__init__()
            self.returns: list[float] = []
            self.lengths: list[int] = []
            self.ended_at: list[int] = []
            self.recent: deque[float] = deque(maxlen=RUNNING)
            self.bar = tqdm(
                total=timesteps, unit="step", disable=not progress, file=sys.stderr, dynamic_ncols=True, smoothing=0.1
            )

        def _on_step(self) -> bool:
            for info in self.locals["infos"]:
                if "episode" in info:
                    self.returns.append(float(info["episode"]["r"]))
                    self.lengths.append(int(info["episode"]["l"]))
                    self.ended_at.append(self.num_timesteps)
                    self.recent.append(self.returns[-1])
            self.bar.update(self.num_timesteps - self.bar.n)
            if self.recent:
                self.bar.set_postfix_str(
                    f"episodes {len(self.returns)}, mean return (last {len(self.recent)}) {np.mean(self.recent):.1f}",
                    refresh=False,
                )
            return True

    vec_env = make_env(world, episode_seconds, sectors, n_envs, seed)
    log = EpisodeLog()
    try:
        model = PPO(
            "MlpPolicy",
            vec_env,
            n_steps=n_steps or max(1, 1024 // n_envs),
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
        start = time.perf_counter()
        model.learn(total_timesteps=timesteps, callback=log)
        seconds = time.perf_counter() - start
    finally:
        log.bar.close()
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
    p.add_argument(
        "--envs", type=int, default=DEFAULT_ENVS, help=f"worlds stepped together in the batch (default {DEFAULT_ENVS})"
    )
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--out", default="runs/ppo", help="folder for the curve, the episodes and the policy")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    args = p.parse_args(argv)
    try:
        import stable_baselines3  # noqa: F401
    except ImportError:
        print('train_ppo.py needs Stable-Baselines3 and torch: pip install -e ".[rl]"', file=sys.stderr)
        return 2
    if args.timesteps < 1 or args.envs < 1 or not args.episode_seconds > 0:
        p.error("--timesteps and --envs must be at least 1, --episode-seconds positive")
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    training = train(
        args.timesteps,
        world=args.world,
        episode_seconds=args.episode_seconds,
        n_envs=args.envs,
        seed=args.seed,
        progress=not args.no_progress,
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
