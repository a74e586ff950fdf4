"""`racecar-sim launch FILE.launch [name:=value ...]`: a roslaunch file run in the sim.

The original stack's nodes become the sim's own (racecar_sim.launch.mapping); with --ros, every other node is
started as a real ROS 1 process through the bridge and the parameter tree goes to the ROS parameter server.
Without --duration the run goes on, paced to the wall clock, until Ctrl-C (as roslaunch and Gazebo do); with it,
the sim runs as fast as it can unless --realtime. A file with no car (the original teleop.launch) runs with --ros
as roslaunch would: its nodes join the master of a sim already running with --ros.
"""

from __future__ import annotations

import argparse
import contextlib
import signal
import sys
import time
from pathlib import Path

from racecar_sim.cli.args import (
    add_overwrite_argument,
    add_ros_path_options,
    add_sensor_arguments,
    apply_ros_path_options,
    check_folder,
    check_record_path,
    make_folder,
    positive_float,
    seed_value,
    sensor_options,
    xacro_arg,
)
from racecar_sim.cli.live import RealTimePacer
from racecar_sim.cli.terminal import RawTerminal, stdin_is_tty
from racecar_sim.core.errors import ConfigError, RecordingError
from racecar_sim.launch import LaunchPlan, LaunchRun, RosOnlyLaunch, has_car, load_launch, map_plan

CHUNK = 0.05  # s of sim time between looks at the keyboard and the clock
QUIT_KEYS = ("\x03", "q")


def add_parser(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser("launch", help="run a roslaunch file (the original racecar_gazebo ones, or a user's own)")
    p.__class__ = type("LaunchParser", (_LaunchArgs, type(p)), {})  # keeps the CLI's one-line errors
    p.add_argument("file", metavar="FILE.launch", help="the roslaunch XML file")
    p.add_argument(
        "launch_args",
        nargs="*",
        type=xacro_arg,
        metavar="NAME:=VALUE",
        help="the launch file's args, as on roslaunch's command line",
    )
    p.add_argument(
        "--duration",
        type=positive_float,
        metavar="S",
        help="sim seconds to run (default: until Ctrl-C, in real time); with --ros and no car in the file, "
        "wall seconds",
    )
    p.add_argument("--realtime", action="store_true", help="run no faster than real time")
    p.add_argument(
        "--ros",
        action="store_true",
        help="connect to ROS 1 (ROS_MASTER_URI, or a roscore started on 127.0.0.1): the parameters go to "
        "the parameter server and nodes the sim has no equivalent for start as ROS processes",
    )
    p.add_argument(
        "--record",
        metavar="FILE.mcap",
        help="record every topic to this MCAP (default OUT/run.mcap with --out, else none)",
    )
    p.add_argument("--out", metavar="DIR", help="folder for the run's files (the recording)")
    add_overwrite_argument(p)
    p.add_argument("--seed", type=seed_value, default=0, help="random seed, a whole number >= 0 (default 0)")
    p.add_argument(
        "--model-path",
        action="append",
        default=[],
        metavar="DIR",
        help="folder holding model:// models, searched before GAZEBO_MODEL_PATH (repeatable)",
    )
    add_ros_path_options(p)
    add_sensor_arguments(p)


class _LaunchArgs(argparse.ArgumentParser):
    """`name:=value` words count as launch args wherever they stand, before or after the options (as roslaunch's)."""

    def parse_known_args(self, args=None, namespace=None):
        words = list(sys.argv[1:] if args is None else args)
        pairs = [w for w in words if ":=" in w and not w.startswith("-")]
        namespace, extras = super().parse_known_args([w for w in words if w not in pairs], namespace)
        try:
            namespace.launch_args = [xacro_arg(w) for w in pairs]
        except argparse.ArgumentTypeError as exc:
            self.error(str(exc))
        return namespace, extras


def _record_path(args: argparse.Namespace) -> Path | None:
    record = Path(args.record) if args.record else Path(args.out) / "run.mcap" if args.out else None
    if args.out:
        check_folder("--out", Path(args.out))
    if record is not None:
        check_record_path(record, overwrite=args.overwrite)
    return record


def _terminate(signum: int, frame: object) -> None:
    raise KeyboardInterrupt


def main(args: argparse.Namespace) -> int:
    signal.signal(signal.SIGTERM, _terminate)
    record = _record_path(args)
    apply_ros_path_options(args)
    launch_args = dict(args.launch_args)
    plan = load_launch(args.file, launch_args)
    if args.ros and not has_car(plan):
        return _run_ros_only(args, plan)
    sensors = sensor_options(args)
    setup = map_plan(
        plan, ros=args.ros, lidar=sensors["lidar"], camera=sensors["camera"], sensors_off=sensors["sensors_off"]
    )
    with LaunchRun(
        setup, seed=args.seed, sensor_noise=not args.no_noise, model_path=args.model_path, ros=args.ros
    ) as run:
        sim = run.sim
        recording = None
        if record is not None:  # the file taken exclusively (an existing one only with --overwrite)
            from racecar_sim.recording import RunRecording  # mcap loads only when a launch records

            make_folder("--record", record.parent)
            try:
                recording = RunRecording(
                    sim.bus, lambda: sim.time_ns, record, raw_images=True, overwrite=args.overwrite
                )
            except RecordingError as exc:  # taken by another run since the look before, or cannot be created
                raise RecordingError(f"--record {exc}") from None
        print(
            f"launch {plan.file.name}: world {sim.world.name}, cars {', '.join(c.model_name for c in sim.cars)}"
            + (f", {len(setup.ros_nodes)} ROS nodes" if args.ros else ""),
            file=sys.stderr,
        )
        try:
            interrupted = _run(args, run)
        finally:
            if recording is not None:
                recording.close()  # what the writer process holds, then the summary and footer
        for car in sim.cars:
            pos, _ = car.state.base_pose()
            print(f"{car.model_name:<10} x {pos[0]:.3f} m, y {pos[1]:.3f} m at sim time {sim.time:.2f} s")
    if record is not None:
        print(f"wrote {record}")
    return 130 if interrupted else 0


def _run_ros_only(args: argparse.Namespace, plan: LaunchPlan) -> int:
    """A launch file with no car (the original teleop.launch): its nodes on the master of a sim already running
    with --ros, until they all exit, --duration wall seconds pass, or Ctrl-C."""
    with RosOnlyLaunch(plan) as launch:
        print(
            f"launch {plan.file.name}: no car, {launch.running} ROS nodes on {launch.ros.master_uri}", file=sys.stderr
        )
        end = None if args.duration is None else time.monotonic() + args.duration
        try:
            while launch.running and (end is None or time.monotonic() < end):
                time.sleep(CHUNK)
        except KeyboardInterrupt:
            return 130
    return 0


def _run(args: argparse.Namespace, run: LaunchRun) -> bool:
    """Run to --duration (or until Ctrl-C), handing keys to the launch's keyboard_teleop; True if interrupted."""
    sim, duration = run.sim, args.duration
    realtime = args.realtime or duration is None
    keyboard = bool(run.teleops) and stdin_is_tty()
    if run.teleops and not keyboard:
        print("racecar-sim: keyboard_teleop.py needs a terminal on stdin: the car gets no keys", file=sys.stderr)
    pacer = RealTimePacer()
    try:
        with RawTerminal(sys.stdin.fileno()) if keyboard else contextlib.nullcontext() as terminal:
            while duration is None or sim.time < duration - 1e-9:
                for key in terminal.read_keys() if terminal is not None else "":
                    if key in QUIT_KEYS:
                        return False
                    for teleop in run.teleops:
                        teleop.key(key)
                if sim.paused:
                    if run.bridge is None:
                        raise ConfigError(
                            f"{args.file}: the world starts paused (gazebo -u, paused:=true) and nothing "
                            "unpauses it without --ros: run with paused:=false, or with --ros and call "
                            "/gazebo/unpause_physics"
                        )
                    run.bridge.spin_once(timeout=CHUNK)  # answers /gazebo/unpause_physics while sim time stands
                    continue
                sim.run_until(sim.time + CHUNK if duration is None else min(sim.time + CHUNK, duration))
                if realtime:
                    pacer.wait(sim.time)
    except KeyboardInterrupt:
        return True
    return False
