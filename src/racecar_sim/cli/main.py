"""Entry point of `racecar-sim`: one subcommand per module of this package."""

from __future__ import annotations

import argparse
import logging
import sys
import warnings

from racecar_sim import __version__
from racecar_sim.cli import bench, describe, launch, recover, ros_env, run, sweep, teleop, worlds
from racecar_sim.core.errors import RacecarSimError

SUBCOMMANDS = {"run": run, "teleop": teleop, "launch": launch, "describe": describe, "bench": bench, "worlds": worlds,
               "recover": recover, "ros-env": ros_env, "sweep": sweep}


class _Parser(argparse.ArgumentParser):
    """Bad arguments: one line naming the problem, exit code 2."""

    def error(self, message: str) -> None:  # type: ignore[override]
        self.exit(2, f"{self.prog}: error: {message} (see --help)\n")


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="racecar-sim", description="The MIT RACECAR simulator, without ROS or Gazebo.")
    parser.add_argument("--version", action="version", version=f"racecar-sim {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name, module in SUBCOMMANDS.items():
        module.add_parser(sub)
    return parser


def _one_line_warning(message, category, filename, lineno, line=None) -> str:  # noqa: ANN001 (warnings' hook)
    return f"racecar-sim: warning: {message}\n"


def main(argv: list[str] | None = None) -> int:
    logging.basicConfig(level=logging.WARNING, format="racecar-sim: %(message)s")
    warnings.formatwarning = _one_line_warning
    parser = build_parser()
    args = parser.parse_args(argv)
    if args.command is None:
        args = parser.parse_args(["run", *(argv or [])])
    try:
        return SUBCOMMANDS[args.command].main(args)
    except RacecarSimError as exc:
        print(f"racecar-sim: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("racecar-sim: interrupted", file=sys.stderr)
        return 130
