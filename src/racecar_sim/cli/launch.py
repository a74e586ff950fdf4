"""`racecar-sim launch FILE.launch [name:=value ...]`: a roslaunch file run in the sim.

The original stack's nodes become the sim's own (racecar_sim.launch.mapping); with --ros, every other node is
started as a real ROS 1 process through the bridge and the parameter tree goes to the ROS parameter server.
Without --duration the run goes on, paced to the wall clock, until Ctrl-C (as roslaunch and Gazebo do); with it,
the sim runs as fast as it can unless --realtime, or a ROS bridge (--ros, --ros2) paces it; --fast runs ahead of the
wall clock in every case. A file with no car (the original teleop.launch) runs with --ros
as roslaunch would: its nodes join the master of a sim already running with --ros.
"""

from __future__ import annotations

import argparse
import contextlib
import signal
import sys
import time
from typing import TYPE_CHECKING

from racecar_sim.cli.args import (
    add_driver_arguments,
    add_ros_path_options,
    add_run_options,
    add_vehicle_argument,
    apply_ros_path_options,
    per_car,
    positive_float,
    seed_value,
    sensor_options,
    xacro_arg,
)
from racecar_sim.cli.live import LiveViews, RealTimePacer, bridged, paced
from racecar_sim.cli.ros2_env import check_ros2, start_ros2_bridge
from racecar_sim.cli.run_folder import (
    RunFolder,
    node_failure_fields,
    node_failure_note,
    node_failure_title,
    output_paths,
)
from racecar_sim.cli.terminal import RawTerminal, StopSignals, stdin_is_tty
from racecar_sim.cli.topic_map import check_topic_map
from racecar_sim.core.errors import ConfigError, NodeError
from racecar_sim.core.names import TELEOP
from racecar_sim.launch import LaunchPlan, LaunchRun, RosOnlyLaunch, has_car, load_launch, map_plan
from racecar_sim.runtime.driving import attach_driver, driver_settings

if TYPE_CHECKING:
    from racecar_sim.bridges.ros2 import Ros2Bridge

CHUNK = 0.05  # s of sim time between looks at the keyboard and the clock
BRIDGED_CHUNK = 0.01  # the same, paced with a ROS bridge: what a slice publishes reaches ROS in its time
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
    p.add_argument("--seed", type=seed_value, default=0, help="random seed, a whole number >= 0 (default 0)")
    p.add_argument(
        "--model-path",
        action="append",
        default=[],
        metavar="DIR",
        help="folder holding model:// models, searched before GAZEBO_MODEL_PATH (repeatable)",
    )
    add_ros_path_options(p)
    add_vehicle_argument(p)
    add_driver_arguments(p, "Default: the drivers the launch file starts (each car's own --driver is over them)")
    add_run_options(
        p,
        default_out="none: no files unless --out or --record",
        ros_help="connect to ROS 1 (ROS_MASTER_URI, or a roscore started on 127.0.0.1): the parameters go to "
        "the parameter server and nodes the sim has no equivalent for start as ROS processes",
        paced_by_default="without --duration",
    )


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


def _terminate(signum: int, frame: object) -> None:
    raise KeyboardInterrupt


def main(args: argparse.Namespace) -> int:
    signal.signal(signal.SIGTERM, _terminate)
    check_topic_map(args)
    paced(args)  # --realtime with --fast: one line, before anything is built
    out, record = output_paths(args, None)
    apply_ros_path_options(args)
    check_ros2(args)
    launch_args = dict(args.launch_args)
    plan = load_launch(args.file, launch_args)
    if args.ros and not has_car(plan):
        return _run_ros_only(args, plan)
    sensors = sensor_options(args)
    vehicle = {} if args.vehicle is None else {"vehicle": args.vehicle}
    setup = map_plan(
        plan,
        ros=args.ros,
        lidar=sensors["lidar"],
        camera=sensors["camera"],
        sensors_off=sensors["sensors_off"],
        **vehicle,
    )
    with LaunchRun(
        setup,
        seed=args.seed,
        sensor_noise=not args.no_noise,
        model_path=args.model_path,
        ros=args.ros,
        master_uri=args.ros_master,
        topic_map=args.topic_map,
        start_line=args.start_line,
    ) as run:
        sim = run.sim
        drivers = _drive_options(args, run)
        print(
            f"launch {plan.file.name}: world {sim.world.name}, cars {', '.join(c.model_name for c in sim.cars)}"
            + (f", {len(setup.ros_nodes)} ROS nodes" if args.ros else ""),
            file=sys.stderr,
        )
        if all(driver == NOBODY for driver in drivers) and not (args.ros and setup.ros_nodes):
            print(
                f"racecar-sim: {plan.file.name} starts no driver, so the car stands still: give --driver wall-follow "
                "(or your own, --driver my_driver.py:MyDriver), --viewer and its WASD keys, or drive it from a ROS "
                "node on /vesc/ackermann_cmd_mux/input/navigation or .../teleop (--ros, --ros2)",
                file=sys.stderr,
            )
        start = time.perf_counter()
        with (
            RunFolder(args, sim, out, record) as folder,
            _closing(start_ros2_bridge(args, sim)) as ros2,
            LiveViews(sim, args.viewer, args.foxglove, run.teleops[0] if run.teleops else None) as live,
        ):
            failure: NodeError | None = None
            try:
                interrupted = _run(args, run, ros2, live)
            except NodeError as exc:  # a user's --driver raised: the files hold the run up to that event
                interrupted, failure = False, exc
        wall = time.perf_counter() - start
        for car in sim.cars:
            pos, _ = car.state.base_pose()
            print(f"{car.model_name:<10} x {pos[0]:.3f} m, y {pos[1]:.3f} m at sim time {sim.time:.2f} s")
    title = f"{sim.world.name}: launch {plan.file.name}, {sim.time:.0f} s sim, seed {sim.seed}"
    if failure is not None:
        extra = {"launch_file": str(plan.file), **node_failure_fields(failure)}
        folder.finish(node_failure_title(title, failure), [], wall, drivers, extra, poses=False)
        node_failure_note(failure)
        return NodeError.EXIT_CODE
    folder.finish(title, [], wall, drivers, {"launch_file": str(plan.file)}, poses=False)
    return 130 if interrupted else 0


NOBODY = "none"  # a car nothing of the launch file drives


def _drive_options(args: argparse.Namespace, run: LaunchRun) -> list[str]:
    """Attach --driver (with --driver-config) to the cars it names, over the launch file's own; each car's driver
    as the summary names it: the launch file's sim driver node, keyboard_teleop.py, joy_teleop.py, --driver, or
    NOBODY."""
    sim, setup = run.sim, run.setup
    names = [car.model_name for car in sim.cars]
    fleet = len(sim.cars) > 1 or bool(sim.cars[0].name)
    chosen = per_car(args.driver, "--driver", names, fleet)
    files = per_car(args.driver_config, "--driver-config", names, fleet)
    drivers = [NOBODY] * len(names)
    for spec in setup.drivers:
        drivers[names.index(sim.car_named(spec.car).model_name)] = spec.kind
    for index, car in enumerate(sim.cars):
        teleop_topics = {car.topic(TELEOP)}
        if any(topic in teleop_topics for topic in setup.teleop_topics) and drivers[index] == NOBODY:
            drivers[index] = "keyboard_teleop.py"
    for joy in setup.joy_teleops:
        index = names.index(sim.car_named(joy.car).model_name)
        drivers[index] = "joy_teleop.py" if drivers[index] == NOBODY else drivers[index]
    for index, (car, driver, path) in enumerate(zip(sim.cars, chosen, files)):
        if driver is None:
            if path is not None:
                raise ConfigError(f"--driver-config {path}: give --driver too (the launch file's drivers take ~params)")
            continue
        attach_driver(sim, car, driver, driver_settings(path, driver) if path is not None else {})
        drivers[index] = driver
    return drivers


def _run_ros_only(args: argparse.Namespace, plan: LaunchPlan) -> int:
    """A launch file with no car (the original teleop.launch): its nodes on the master of a sim already running
    with --ros, until they all exit, --duration wall seconds pass, or Ctrl-C."""
    # Ctrl-C (or SIGTERM) is noted and the loop ends: a KeyboardInterrupt raised inside Popen.poll() could leave the
    # node's wait lock taken, and stopping the node then waited on it for ever
    with StopSignals() as signals, RosOnlyLaunch(plan) as launch:
        print(
            f"launch {plan.file.name}: no car, {launch.running} ROS nodes on {launch.ros.master_uri}", file=sys.stderr
        )
        end = None if args.duration is None else time.monotonic() + args.duration
        while launch.running and signals.received is None and (end is None or time.monotonic() < end):
            time.sleep(CHUNK)
    return 0 if signals.received is None else 130


def _closing(bridge: Ros2Bridge | None) -> contextlib.AbstractContextManager[Ros2Bridge | None]:
    """The --ros2 bridge (or None), closed on the way out."""
    return contextlib.closing(bridge) if bridge is not None else contextlib.nullcontext()


def _run(
    args: argparse.Namespace, run: LaunchRun, ros2: Ros2Bridge | None = None, live: LiveViews | None = None
) -> bool:
    """Run to --duration (or until Ctrl-C or the viewer closes), handing keys to the launch's keyboard_teleop and
    keeping the live views current; True if interrupted."""
    sim, duration = run.sim, args.duration
    watched = live is not None and live.realtime
    realtime = paced(args, default=duration is None) or watched
    chunk = BRIDGED_CHUNK if (realtime and bridged(args)) or watched else CHUNK
    keyboard = bool(run.teleops) and stdin_is_tty()
    if run.teleops and not keyboard:
        print("racecar-sim: keyboard_teleop.py needs a terminal on stdin: the car gets no keys", file=sys.stderr)
    pacer = RealTimePacer()
    try:
        with RawTerminal(sys.stdin.fileno()) if keyboard else contextlib.nullcontext() as terminal:
            while (duration is None or sim.time < duration - 1e-9) and not (live is not None and live.closed):
                for key in terminal.read_keys() if terminal is not None else "":
                    if key in QUIT_KEYS:
                        return False
                    for teleop in run.teleops:
                        teleop.key(key)
                if sim.paused:
                    bridges = [b for b in (run.bridge, ros2) if b is not None]
                    if not bridges:
                        raise ConfigError(
                            f"{args.file}: the world starts paused (gazebo -u, paused:=true) and nothing "
                            "unpauses it without --ros: run with paused:=false, or with --ros and call "
                            "/gazebo/unpause_physics (--ros2: /unpause_physics)"
                        )
                    for bridge in bridges:  # answers unpause_physics while sim time stands
                        bridge.spin_once(timeout=CHUNK / len(bridges))
                    continue
                sim.run_until(sim.time + chunk if duration is None else min(sim.time + chunk, duration))
                if run.bridge is not None:
                    run.bridge.spin_once()  # what the slice published goes to ROS now, not after the pause
                if live is not None:
                    live.update()
                if realtime:
                    pacer.wait(sim.time)
    except KeyboardInterrupt:
        return True
    return False
