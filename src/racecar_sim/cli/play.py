"""`racecar-sim play POLICY.zip`: a trained Stable-Baselines3 policy drives the car, and the run leaves the folder
`racecar-sim run` leaves (run.mcap, summary.png, camera.mp4, the printed summary).

The policy (PPO.load; what examples/train_ppo.py writes, or any PPO trained on DriveEnv's observation) drives through
a PolicyDriver node (envs/policy.py): at the control rate (20 Hz, DriveEnv's) it sees the car's observation as
DriveEnv builds it and publishes its action as DriveEnv does, so the car drives as it did in training. Everything
else is `racecar-sim run`'s own code, with its options (world, duration, out, record, sensors, viewer, cars, ...):
only the driver options do not apply. Needs the `[rl]` extra (Stable-Baselines3 and torch).
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from racecar_sim.cli import run as run_command
from racecar_sim.cli.args import positive_float
from racecar_sim.core.errors import ConfigError
from racecar_sim.envs.drive import CONTROL_RATE
from racecar_sim.runtime import Car, Simulator

# run's options that choose or tune its built-in drivers: hidden here, and refused when given (the policy drives)
DRIVER_OPTIONS = ("driver", "driver_config", *run_command.OPTION_DRIVERS)
NEEDS_RL = 'racecar-sim play needs Stable-Baselines3 and torch: pip install -e ".[rl]" (the [rl] extra)'


def add_parser(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    scratch = argparse.ArgumentParser(add_help=False).add_subparsers()
    run_command.add_parser(scratch)
    base = scratch.choices["run"]  # run's parser: play takes its options, the same code reads them
    for action in base._actions:
        if action.dest in DRIVER_OPTIONS:
            action.help = argparse.SUPPRESS
    p = sub.add_parser(
        "play",
        parents=[base],
        add_help=False,  # -h comes with run's options
        help="a trained policy (Stable-Baselines3 PPO .zip) drives; writes the run folder as `run` does",
        description=__doc__.split("\n\n")[0],
    )
    p.add_argument("policy", metavar="POLICY.zip", help="the policy: a Stable-Baselines3 PPO saved with .save()")
    p.add_argument(
        "--control-rate",
        type=positive_float,
        default=CONTROL_RATE,
        metavar="HZ",
        help=f"Hz of the policy's actions: the env's control_rate it was trained at (default {CONTROL_RATE:g})",
    )
    p.add_argument(
        "--stochastic",
        action="store_true",
        help="sample each action from the policy's distribution (default: its deterministic action)",
    )


def main(args: argparse.Namespace) -> int:
    for dest in DRIVER_OPTIONS:
        if getattr(args, dest, None) not in (None, False, []):
            raise ConfigError(f"--{dest.replace('_', '-')} does not apply to play: the policy drives")
    path = Path(args.policy)
    if not path.is_file():
        raise ConfigError(f"policy {path}: no such file (a .zip written by a Stable-Baselines3 model's save())")
    model = _load(path)
    from racecar_sim.envs.policy import attach_policy, sb3_policy

    def attach(args: argparse.Namespace, sim: Simulator, car: Car) -> object:
        if car.lidar is None:
            raise ConfigError("the policy observes the lidar: drop --no-lidar (or DISABLE_GAZEBO_LASER)")
        spec = car.lidar.spec
        policy, mode, limits = sb3_policy(model, spec.range_max, spec.samples, deterministic=not args.stochastic)
        return attach_policy(sim, car, policy, mode, limits, rate=args.control_rate)

    args.driver = f"policy {path.name}"
    return run_command.main(args, attach=attach)


def _load(path: Path) -> Any:
    """The PPO model saved at `path` (on the CPU); ConfigError (one line) without Stable-Baselines3 or for a file
    that is not one."""
    try:
        from stable_baselines3 import PPO
    except ImportError:
        raise ConfigError(NEEDS_RL) from None
    try:
        return PPO.load(path, device="cpu")
    except Exception as exc:  # a zip of another kind, a model of another algorithm, a corrupt file
        reason = " ".join(str(exc).split()) or type(exc).__name__
        raise ConfigError(f"policy {path}: not a Stable-Baselines3 PPO model ({reason[:200]})") from None
