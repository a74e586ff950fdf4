"""`racecar-sim teleop`: keyboard_teleop.py in a terminal, driving the simulated car in real time; with `--joy`, a
gamepad through joy_node and joy_teleop.py instead, as racecar-v2-teleop.launch.xml runs them in `<group ns="vesc">`."""

from __future__ import annotations

import argparse
import contextlib
import math
import os
import sys
import time
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, TextIO, TypeVar

import numpy as np

from racecar_sim.cli.args import (
    add_ros_path_options,
    add_run_options,
    add_world_arguments,
    add_xacro_arguments,
    apply_ros_path_options,
    finite_float,
    positive_float,
    seed_value,
    sensor_options,
    xacro_options,
)
from racecar_sim.cli.live import LiveViews, RealTimePacer
from racecar_sim.cli.ros2_env import check_ros2, start_ros2_bridge
from racecar_sim.cli.ros_env import check_ros, start_ros_bridge
from racecar_sim.cli.run_folder import RunFolder, output_paths
from racecar_sim.cli.spawns import check_spawn_option
from racecar_sim.cli.terminal import RawTerminal, StopSignals, stdin_is_tty
from racecar_sim.cli.topic_map import check_topic_map
from racecar_sim.control.joy import JOY, JoyNode
from racecar_sim.control.joy_teleop import JoyCommand, JoyTeleop, joy_teleop_yaml, load_joy_teleop
from racecar_sim.control.teleop import TELEOP, KeyboardTeleop, load_teleop_config
from racecar_sim.core.errors import ConfigError
from racecar_sim.core.transforms import yaw_of
from racecar_sim.msgs import AckermannDriveStamped, Odometry
from racecar_sim.runtime import Simulator
from racecar_sim.worlds import World, load_world

if TYPE_CHECKING:  # mcap loads only when a session records, pygame only with --joy
    from racecar_sim.bridges.ros1 import RosBridge
    from racecar_sim.bridges.ros2 import Ros2Bridge
    from racecar_sim.control.joy_device import Gamepad
    from racecar_sim.recording import RunRecording

SLICE = 0.02  # s of sim time between two looks at the keyboard
STATUS_PERIOD = 0.1  # s of wall time between status line redraws
SETTLE = 0.05  # s of sim time after the final zero command, so that it reaches the wheels
QUIT_KEYS = ("q", "Q", "\x03")  # raw mode hands Ctrl-C over as "\x03"
NOT_A_TTY = "teleop reads keys from a terminal (stdin is not a TTY); use --viewer, or run it in a terminal"
NO_KEYBOARD = "teleop has no keyboard: stdin is not a TTY and the viewer did not open"
_B = TypeVar("_B", "RosBridge", "Ros2Bridge")


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
    p.add_argument(
        "--joy",
        nargs="?",
        const="",
        metavar="DEVICE",
        help="drive with a gamepad instead of the keys, as the real car's joy_node + joy_teleop.py with "
        "racecar/config/racecar-v2/joy_teleop.yaml (hold button 4, LB: axis 1 speed, axis 3 steering); DEVICE: an "
        "index, /dev/input/jsN or a name (default: the first gamepad). Needs pip install 'racecar-sim[joy]'",
    )
    add_xacro_arguments(p)
    add_ros_path_options(p)
    add_run_options(p, default_out="none: no files unless --out or --record")
    for action in p._actions:  # the shared pacing flags, as they apply to a person driving
        if action.dest == "realtime":
            action.help = "run no faster than real time: teleop always does, a person drives"
        elif action.dest == "fast":
            action.help = "refused: teleop runs in real time, as a person drives (for run and launch)"


class Joystick:
    """`--joy`: the gamepad, joy_node (/vesc/joy) and joy_teleop.py with the racecar package's joy_teleop.yaml."""

    def __init__(self, sim: Simulator, device: Gamepad, config_file: Path) -> None:
        config, commands = load_joy_teleop(config_file)
        self.device, self.commands, self.config_file = device, commands, config_file
        joy = sim.add_node(lambda ctx: JoyNode(ctx.bus, ctx.timers, ctx.now, device, config))
        teleop = sim.add_node(lambda ctx: JoyTeleop(ctx.bus, commands))
        assert isinstance(joy, JoyNode) and isinstance(teleop, JoyTeleop)
        self.joy, self.teleop = joy, teleop
        self.stopped = False

    def stop(self) -> None:
        """The gamepad is no longer read: nothing drives after the session's final zero command."""
        self.joy.close()
        self.stopped = True

    def state(self) -> str:
        """The status line's part: the command the held buttons run, or why there is none."""
        if self.stopped:
            return "joy: off"
        if not self.joy.connected:
            return "joy: no gamepad"
        if self.teleop.received == 0:
            return "joy: waiting"
        return f"joy: {self.teleop.command or 'no command'}"

    def banner(self) -> list[str]:
        lines = [
            f"Reading gamepad {self.device.name} and publishing sensor_msgs/Joy on {JOY}; joy_teleop.py with "
            f"{self.config_file}:",
        ]
        lines += [f"  {_describe(c, self.teleop.topics[c.name])}" for c in self.commands]
        return lines + ["q or CTRL-C to quit", ""]


def _describe(command: JoyCommand, topic: str) -> str:
    held = f"hold buttons {list(command.buttons)}" if command.buttons else "no buttons"
    if command.is_default:
        held += " (or any unmapped ones)"
    if command.values is not None:
        what = ", ".join(f"{target} = {value}" for target, value in command.values)
    else:
        what = ", ".join(f"{m.target} = axis {m.axis} x {m.scale:g}" for m in command.axis_mappings)
    return f"{held}: {command.name}, {what} on {topic}"


class Dashboard:
    """What the status line and the summary show, from /vesc/odom and both muxes."""

    def __init__(self, sim: Simulator, record: str | None, stream: TextIO, joystick: Joystick | None = None) -> None:
        self.sim, self.record, self.stream, self.joystick = sim, record, stream, joystick
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

    def velocity(self) -> tuple[float, float]:
        """Speed along the car's heading (m/s) and yaw rate (rad/s) of the last odometry: the twist is in the world
        frame with the original's odometry, in the car's with `ros`."""
        if self.odom is None:
            return 0.0, 0.0
        twist = self.odom.twist.twist
        if self.sim.car.odometry_mode == "ros":
            return twist.linear.x, twist.angular.z
        yaw = self.pose()[2]
        return twist.linear.x * math.cos(yaw) + twist.linear.y * math.sin(yaw), twist.angular.z

    def write(self, text: str) -> None:
        """Write to the terminal, which may have gone away (SIGHUP) by now."""
        with contextlib.suppress(OSError, ValueError):
            self.stream.write(text)
            self.stream.flush()

    def help(self, speed: float, turn: float, terminal: bool) -> None:
        """The original's banner, once, above the status line."""
        if self.joystick is not None:
            self.write("\r\n".join(self.joystick.banner()) + "\r\n")
            return
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
        speed, yaw_rate = self.velocity()
        line = (
            f"t {self.sim.time:7.2f} s | v {speed:+5.2f} m/s | yaw rate {yaw_rate:+5.2f} rad/s | "
            f"steer {self.steering:+5.2f} rad | x {x:+7.2f} y {y:+7.2f} yaw {yaw:+5.2f} | {self._rtf:4.2f}x | "
            f"{self.chain.in_control()}"
        )
        if self.joystick is not None:
            line += f" | {self.joystick.state()}"
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
    keys_drive: bool = True,
    bridges: Sequence[Ros2Bridge] = (),
    ros: RosBridge | None = None,
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
            if keys_drive:  # with --joy the gamepad drives; the keys only quit
                teleop.key(ch)
        end = sim.time + SLICE if duration is None else min(sim.time + SLICE, duration)
        sim.run_until(end)
        for bridge in bridges if sim.paused else ():  # sim time stands: the bridge still answers unpause_physics
            bridge.spin_once(SLICE)
        if ros is not None:  # what the slice published goes to ROS 1 now; commands from it come in
            ros.spin_once(SLICE if sim.paused else 0.0)
        views.update()
        dashboard.draw()
        pacer.wait(sim.time)


def _gamepad(selector: str | None) -> Gamepad | None:
    """--joy: the gamepad, opened before the sim is built (None without --joy); no gamepad, or no pygame-ce, is
    one line and exit code 2."""
    if selector is None:
        return None
    from racecar_sim.control.joy_device import GamepadUnavailable, open_gamepad  # pygame only with --joy

    try:
        return open_gamepad(selector or None)
    except GamepadUnavailable as exc:
        raise ConfigError(f"teleop --joy: {exc}") from None


def main(args: argparse.Namespace) -> int:
    """Drive the car from the keyboard until q, Ctrl-C, --duration, or a closed viewer."""
    check_topic_map(args)
    if args.fast:
        raise ConfigError("teleop runs in real time, as a person drives: --fast is for run and launch")
    check_ros(args)
    check_ros2(args)
    interactive = stdin_is_tty()
    if not interactive and not args.viewer and args.joy is None:
        raise ConfigError(NOT_A_TTY)
    device = _gamepad(args.joy)
    out, record = output_paths(args, None)
    apply_ros_path_options(args)
    joy_config = joy_teleop_yaml() if device is not None else None  # $(find racecar): --package-path first
    if joy_config is not None:
        load_joy_teleop(joy_config)  # a broken joy_teleop.yaml is named before the sim is built
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
            start_line=args.start_line,
            **sensor_options(args),
            **xacro_options(args),
        ) as sim,
    ):
        teleop = KeyboardTeleop(sim.bus, sim.scheduler, lambda: sim.time_ns, args.speed, args.turn, args.hold)
        joystick = Joystick(sim, device, joy_config) if device is not None and joy_config is not None else None
        folder = RunFolder(args, sim, out, record)
        recorder = folder.recording
        dashboard = Dashboard(sim, None if folder.record is None else str(folder.record), sys.stderr, joystick)
        start = time.perf_counter()
        with (
            folder,
            _closing(start_ros_bridge(args, sim)) as ros,
            _closing(start_ros2_bridge(args, sim)) as ros2,
            LiveViews(sim, args.viewer, args.foxglove, teleop) as views,
        ):
            if not interactive and views.viewer is None and joystick is None:
                raise ConfigError(NO_KEYBOARD)
            with RawTerminal(sys.stdin.fileno()) if interactive else contextlib.nullcontext() as terminal:
                dashboard.help(teleop.speed, teleop.turn, interactive)
                try:
                    reason = _session(
                        sim,
                        teleop,
                        views,
                        terminal,
                        dashboard,
                        signals,
                        args.duration,
                        keys_drive=joystick is None,
                        bridges=[ros2] if ros2 is not None else [],
                        ros=ros,
                    )
                    if joystick is not None:
                        joystick.stop()
                    teleop.stop()
                    sim.run_until(sim.time + SETTLE)
                finally:
                    dashboard.finish()  # whatever is printed next starts on a line of its own
        wall = time.perf_counter() - start
    with contextlib.suppress(OSError):  # stdout may be a terminal that hung up
        print(dashboard.summary(reason, recorder), flush=True)
    with contextlib.suppress(OSError):  # the files are written before the summary is printed
        driver = "gamepad (joy_teleop)" if joystick is not None else "keyboard (keyboard_teleop)"
        folder.finish(f"{sim.world.name}: teleop, {driver}, {sim.time:.0f} s sim, seed {sim.seed}", [], wall, [driver])
    return 0 if signals.received is None else 128 + signals.received


def _closing(bridge: _B | None) -> contextlib.AbstractContextManager[_B | None]:
    """A bridge (or None), closed on the way out."""
    return contextlib.closing(bridge) if bridge is not None else contextlib.nullcontext()
