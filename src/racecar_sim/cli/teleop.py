"""`racecar-sim teleop`: keyboard_teleop.py in a terminal, driving the simulated car in real time."""

from __future__ import annotations

import argparse
import contextlib
import math
import os
import sys
import time
from pathlib import Path
from typing import TYPE_CHECKING, TextIO

import numpy as np

from racecar_sim.cli.args import (
    add_overwrite_argument,
    add_ros_path_options,
    add_sensor_arguments,
    add_world_arguments,
    add_xacro_arguments,
    apply_ros_path_options,
    check_record_path,
    finite_float,
    make_folder,
    positive_float,
    seed_value,
    sensor_options,
    xacro_options,
)
from racecar_sim.cli.live import LiveViews, RealTimePacer, add_live_arguments
from racecar_sim.cli.spawns import check_spawn_option
from racecar_sim.cli.terminal import RawTerminal, StopSignals, stdin_is_tty
from racecar_sim.control.teleop import TELEOP, KeyboardTeleop, load_teleop_config
from racecar_sim.core.errors import ConfigError, RecordingError
from racecar_sim.core.transforms import yaw_of
from racecar_sim.msgs import AckermannDriveStamped, Odometry
from racecar_sim.runtime import Simulator
from racecar_sim.worlds import World, load_world

if TYPE_CHECKING:  # mcap loads only when a session records
    from racecar_sim.recording import RunRecording

SLICE = 0.02  # s of sim time between two looks at the keyboard
STATUS_PERIOD = 0.1  # s of wall time between status line redraws
SETTLE = 0.05  # s of sim time after the final zero command, so that it reaches the wheels
QUIT_KEYS = ("q", "Q", "\x03")  # raw mode hands Ctrl-C over as "\x03"
NOT_A_TTY = "teleop reads keys from a terminal (stdin is not a TTY); use --viewer, or run it in a terminal"
NO_KEYBOARD = "teleop has no keyboard: stdin is not a TTY and the viewer did not open"


def _non_negative(text: str) -> float:
    value = finite_float(text)
    if value < 0:
        raise argparse.ArgumentTypeError(f"'{text}' must not be negative")
    return value


def add_parser(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """The `teleop` subcommand and its options."""
    config = load_teleop_config()
    p = sub.add_parser("teleop", help="drive the car from the keyboard (w/a/s/d), in real time")
    add_world_arguments(p)
    p.add_argument(
        "--speed",
        type=finite_float,
        default=config.speed,
        help=f"speed of w/a/d (s: the negative), m/s (default {config.speed:g})",
    )
    p.add_argument(
        "--turn", type=finite_float, default=config.turn, help=f"steering angle of a/d, rad (default {config.turn:g})"
    )
    p.add_argument(
        "--hold",
        type=_non_negative,
        default=config.hold,
        metavar="S",
        help=f"repeat each key's command for S s, bridging the keyboard's auto-repeat delay "
        f"(default {config.hold:g}; 0: one message per key, as the original)",
    )
    p.add_argument(
        "--duration",
        type=positive_float,
        metavar="S",
        help="end the session after S sim seconds (default: at q or Ctrl-C)",
    )
    p.add_argument("--seed", type=seed_value, default=0, help="random seed (default 0)")
    p.add_argument("--record", metavar="FILE.mcap", help="record every topic to an MCAP file")
    add_overwrite_argument(p)
    add_xacro_arguments(p)
    add_ros_path_options(p)
    add_sensor_arguments(p)
    add_live_arguments(p)


class Dashboard:
    """What the status line and the summary show, from /vesc/odom and both muxes."""

    def __init__(self, sim: Simulator, record: str | None, stream: TextIO) -> None:
        self.sim, self.record, self.stream = sim, record, stream
        self.odom: Odometry | None = None
        self.distance = 0.0
        self.steering = 0.0
        self._live = stream.isatty()
        self._next_draw = 0.0
        self._last: tuple[float, float] | None = None  # (wall, sim) at the last redraw
        self._rtf = 0.0
        chain = sim.car.chain
        assert chain is not None, "teleop's car has the mux chain (the default CarNodes)"
        self.chain = chain
        sim.subscribe("/vesc/odom", self._on_odom)
        sim.subscribe(chain.output_topic, self._on_output)

    def _on_odom(self, msg: Odometry) -> None:
        if self.odom is not None:
            a, b = self.odom.pose.pose.position, msg.pose.pose.position
            self.distance += math.hypot(b.x - a.x, b.y - a.y)
        self.odom = msg

    def _on_output(self, msg: AckermannDriveStamped) -> None:
        self.steering = msg.drive.steering_angle

    def pose(self) -> tuple[float, float, float]:
        """x, y, yaw of the last odometry (zeros before the first)."""
        if self.odom is None:
            return 0.0, 0.0, 0.0
        p, q = self.odom.pose.pose.position, self.odom.pose.pose.orientation
        return p.x, p.y, yaw_of(np.array((q.w, q.x, q.y, q.z)))

    def write(self, text: str) -> None:
        """Write to the terminal, which may have gone away (SIGHUP) by now."""
        with contextlib.suppress(OSError, ValueError):
            self.stream.write(text)
            self.stream.flush()

    def help(self, speed: float, turn: float, terminal: bool) -> None:
        """The original's banner, once, above the status line."""
        source = "the keyboard" if terminal else "the viewer window's keys"
        lines = [
            f"Reading from {source} and publishing AckermannDriveStamped on {TELEOP}",
            "---------------------------",
            "Moving around:",
            "        w",
            "   a    s    d",
            f"w forward {speed:g} m/s, a/d forward and steer +/-{turn:g} rad, s reverse",
            "anything else : stop",
            "q or CTRL-C to quit",
            "",
        ]
        self.write("\r\n".join(lines) + "\r\n")  # "\r": a raw terminal may not translate "\n"

    def draw(self, force: bool = False) -> None:
        """Redraw the status line in place, at most every STATUS_PERIOD s of wall time."""
        now = time.perf_counter()
        if not self._live or (now < self._next_draw and not force):
            return
        self._next_draw = now + STATUS_PERIOD
        if self._last is not None and now > self._last[0] and not force:
            rtf = (self.sim.time - self._last[1]) / (now - self._last[0])
            self._rtf = rtf if self._rtf == 0.0 else 0.7 * self._rtf + 0.3 * rtf
        self._last = (now, self.sim.time)
        x, y, yaw = self.pose()
        speed = self.odom.twist.twist.linear.x if self.odom is not None else 0.0
        line = (
            f"t {self.sim.time:7.2f} s | v {speed:+5.2f} m/s | steer {self.steering:+5.2f} rad | "
            f"x {x:+7.2f} y {y:+7.2f} yaw {yaw:+5.2f} | {self._rtf:4.2f}x | {self.chain.in_control()}"
        )
        if self.record:
            line += f" | rec {self.record}"
        with contextlib.suppress(OSError, ValueError):
            line = line[
                : max(10, os.get_terminal_size(self.stream.fileno()).columns - 1)
            ]  # a wrapped line would scroll
        self.write(f"\r{line}\x1b[K")

    def finish(self) -> None:
        """Leave the last status line on screen and start a new one."""
        if self._live:
            self.draw(force=True)
            self.write("\r\n")

    def summary(self, reason: str, recorder: RunRecording | None) -> str:
        """One line: why the session ended, how far the car went, where it is, what was recorded."""
        x, y, yaw = self.pose()
        text = (
            f"teleop: {reason} after {self.sim.time:.2f} s of sim time; {self.distance:.2f} m driven; "
            f"final pose x {x:.3f} y {y:.3f} yaw {yaw:.3f} rad"
        )
        if recorder is not None:
            counts = recorder.message_count
            text += f"; recorded {sum(counts.values())} messages on {len(counts)} topics to {self.record}"
        return text


def _session(
    sim: Simulator,
    teleop: KeyboardTeleop,
    views: LiveViews,
    terminal: RawTerminal | None,
    dashboard: Dashboard,
    signals: StopSignals,
    duration: float | None,
) -> str:
    """Run the sim in real time, SLICE by SLICE, handing keys to teleop; returns why it ended."""
    pacer = RealTimePacer()
    while True:
        if signals.received is not None:
            return "stopped by a signal"
        if duration is not None and sim.time >= duration - 1e-9:
            return "--duration reached"
        if views.closed:
            return "viewer closed"
        try:
            keys = terminal.read_keys() if terminal is not None else ""
        except EOFError:
            return "stdin closed"
        for ch in keys:
            if ch in QUIT_KEYS:
                return "quit"
            teleop.key(ch)
        end = sim.time + SLICE if duration is None else min(sim.time + SLICE, duration)
        sim.run_until(end)
        views.update()
        dashboard.draw()
        pacer.wait(sim.time)


def _recording(args: argparse.Namespace, sim: Simulator) -> RunRecording | None:
    """--record: every topic to the MCAP (camera images raw, as sim.record() records them), written by a writer
    process, the file taken exclusively (an existing one only with --overwrite); None without --record."""
    if not args.record:
        return None
    from racecar_sim.recording import RunRecording  # mcap loads only when a session records

    make_folder("--record", Path(args.record).parent)
    try:
        return RunRecording(sim.bus, lambda: sim.time_ns, args.record, raw_images=True, overwrite=args.overwrite)
    except RecordingError as exc:  # taken by another run since the look before the build, or cannot be created
        raise RecordingError(f"--record {exc}") from None


def main(args: argparse.Namespace) -> int:
    """Drive the car from the keyboard until q, Ctrl-C, --duration, or a closed viewer."""
    interactive = stdin_is_tty()
    if not interactive and not args.viewer:
        raise ConfigError(NOT_A_TTY)
    if args.record:
        check_record_path(Path(args.record), overwrite=args.overwrite)
    apply_ros_path_options(args)
    world: str | World = args.world
    if args.spawn is not None:  # checked here, to name the option
        world = load_world(args.world, args.spawn, [Path(p) for p in args.model_path], args.wall_height)
        check_spawn_option(world, args)
    with (
        StopSignals() as signals,
        Simulator(
            world=world,
            seed=args.seed,
            spawn=args.spawn,
            model_path=args.model_path,
            wall_height=args.wall_height,
            **sensor_options(args),
            **xacro_options(args),
        ) as sim,
    ):
        recorder = _recording(args, sim)
        teleop = KeyboardTeleop(sim.bus, sim.scheduler, lambda: sim.time_ns, args.speed, args.turn, args.hold)
        dashboard = Dashboard(sim, args.record, sys.stderr)
        with recorder or contextlib.nullcontext(), LiveViews(sim, args.viewer, args.foxglove, teleop) as views:
            if not interactive and views.viewer is None:
                raise ConfigError(NO_KEYBOARD)
            with RawTerminal(sys.stdin.fileno()) if interactive else contextlib.nullcontext() as terminal:
                dashboard.help(teleop.speed, teleop.turn, interactive)
                try:
                    reason = _session(sim, teleop, views, terminal, dashboard, signals, args.duration)
                    teleop.stop()
                    sim.run_until(sim.time + SETTLE)
                finally:
                    dashboard.finish()  # whatever is printed next starts on a line of its own
    with contextlib.suppress(OSError):  # stdout may be a terminal that hung up
        print(dashboard.summary(reason, recorder), flush=True)
    return 0 if signals.received is None else 128 + signals.received
