"""Entry point of `racecar-sim`: one subcommand per module of this package."""

from __future__ import annotations

import argparse
import gc
import importlib
import logging
import os
import signal
import sys
import warnings
from collections.abc import Sequence
from types import ModuleType

from racecar_sim import __version__
from racecar_sim.cli import collector, fast_exit
from racecar_sim.core.errors import NodeError, RacecarSimError
from racecar_sim.render.gl import guard_mujoco_import, mujoco_gl_disabled

# the module of each subcommand, in --help's order; only the one being run is imported (start-up time)
SUBCOMMANDS = {
    "run": "run",
    "teleop": "teleop",
    "launch": "launch",
    "describe": "describe",
    "bench": "bench",
    "worlds": "worlds",
    "recover": "recover",
    "ros-env": "ros_env",
    "ros2-env": "ros2_env",
    "sweep": "sweep",
    "play": "play",
}

HOLD_COLLECTOR = ("run",)  # the subcommands that release the held collector themselves, once built (cli/collector.py)
FAST_EXIT = ("run",)  # the subcommands whose process ends without the interpreter's teardown (cli/fast_exit.py)


class _Parser(argparse.ArgumentParser):
    """Bad arguments: one line naming the problem, exit code 2, with the prefix of every other error of the CLI."""

    def error(self, message: str) -> None:  # type: ignore[override]
        self.exit(2, f"racecar-sim: error: {message} (see {self.prog} --help)\n")


def subcommand(name: str) -> ModuleType:
    """The module of subcommand `name` (imported now)."""
    return importlib.import_module(f"racecar_sim.cli.{SUBCOMMANDS[name]}")


def build_parser(commands: Sequence[str] | None = None) -> argparse.ArgumentParser:
    """The parser with the given subcommands (all by default)."""
    parser = _Parser(prog="racecar-sim", description="The MIT RACECAR simulator, without ROS or Gazebo.")
    parser.add_argument("--version", action="version", version=f"racecar-sim {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name in SUBCOMMANDS if commands is None else commands:
        subcommand(name).add_parser(sub)
    return parser


def _command_named(argv: Sequence[str]) -> str | None:
    """The subcommand argv starts with, or None when the top-level parser must see everything (--help,
    --version, no or an unknown command: all subcommands then, so help and errors read as they always did)."""
    if argv and argv[0] in SUBCOMMANDS:
        return argv[0]
    return None


def _one_line_warning(
    message: Warning | str, category: type[Warning], filename: str, lineno: int, line: str | None = None
) -> str:
    return f"racecar-sim: warning: {message}\n"


def main(argv: list[str] | None = None) -> int:
    """Run the subcommand argv names; its exit code. A closed pipe (`racecar-sim describe --urdf | head -5`) ends it
    quietly, as a command killed by SIGPIPE would (exit code 141)."""
    try:
        code = _main(argv)
        sys.stdout.flush()  # a pipe closed early breaks here, not in the interpreter's exit
        return code
    except BrokenPipeError:
        devnull = os.open(os.devnull, os.O_WRONLY)  # the rest of stdout goes nowhere: no second error at exit
        os.dup2(devnull, sys.stdout.fileno())
        os.close(devnull)
        return 128 + signal.SIGPIPE


def entry() -> int:
    """The `racecar-sim` command itself (its console script, `python -m racecar_sim`): main() on the process's own
    arguments, after which a subcommand of FAST_EXIT ends the process without the interpreter's teardown where nothing
    depends on it (cli/fast_exit.py). A program that calls main() gets its exit code back, as always."""
    code = main()
    if code != 128 + signal.SIGPIPE and _command_named(sys.argv[1:]) in FAST_EXIT:
        fast_exit.finish(code)
    return code


def _main(argv: list[str] | None = None) -> int:
    logging.basicConfig(level=logging.WARNING, format="racecar-sim: %(message)s")
    warnings.formatwarning = _one_line_warning
    whole_process = argv is None  # the command itself, not a caller's main([...]) (a test's)
    argv = sys.argv[1:] if argv is None else list(argv)
    command = _command_named(argv)
    if not whole_process:  # importing the subcommand makes ~10^5 objects: not walked while they are made
        gc.disable()
        try:
            with mujoco_gl_disabled():
                parser = build_parser(None if command is None else [command])
        finally:
            gc.enable()
        guard_mujoco_import()
        return _command(parser, argv)
    collector.hold()  # until the subcommand is built (cli/collector.py): `run` releases it before its loop
    try:
        with mujoco_gl_disabled():  # the camera's context comes from sensors.gl, the viewer's from glfw
            parser = build_parser(None if command is None else [command])
        guard_mujoco_import()  # for a subcommand that imports mujoco later
        return _command(parser, argv)
    finally:
        collector.settle()


def _command(parser: argparse.ArgumentParser, argv: list[str]) -> int:
    """Parse argv and run its subcommand."""
    args = parser.parse_args(argv)
    if args.command is None:
        args = parser.parse_args(["run", *argv])
    if args.command not in HOLD_COLLECTOR:
        collector.release()
    return _run(args)


def _run(args: argparse.Namespace) -> int:
    """The subcommand's exit code; the errors a user can cause as one line."""
    try:
        return subcommand(args.command).main(args)
    except RacecarSimError as exc:
        print(f"racecar-sim: error: {exc}", file=sys.stderr)
        return 2
    except NodeError as exc:  # a user's node raised where no run folder was left to mark (its constructor, teleop)
        from racecar_sim.nodes.guard import user_frames

        print(f"racecar-sim: error: {exc}", file=sys.stderr)
        print(user_frames(exc), file=sys.stderr, end="")
        return NodeError.EXIT_CODE
    except KeyboardInterrupt:
        print("racecar-sim: interrupted", file=sys.stderr)
        return 130
