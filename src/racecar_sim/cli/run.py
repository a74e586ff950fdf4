"""`racecar-sim run`: the main job. A driver drives the car in a world; the run leaves a folder to look at.

With no arguments: wall-follow round the `walker` racecourse for 60 s of sim time with the lidar and the
camera on, then runs/<timestamp>/ holds run.mcap, summary.png, summary.json and camera.mp4, and a summary is
printed (cli/run_folder.py: the same folder `teleop`, `launch` and `play` leave).

`--xacro FILE [--xacro-arg name:=value ...]` runs a user's own car: `$(find pkg)` and `package://` resolve through
`--package-path DIR` and ROS_PACKAGE_PATH before the packages racecar-sim ships.

`--cars N` runs a fleet: car1 ... carN (topics /carK/..., frames carK/...), car1 at the world's spawn pose and
each next one `--car-spacing` m behind the one before, along the spawn heading (or back along a track CSV's
centerline), each with its own instance of the run's driver.
"""

from __future__ import annotations

import argparse
import signal
import sys
import time
from collections.abc import Callable
from datetime import datetime
from pathlib import Path
from typing import TYPE_CHECKING

from racecar_sim.cli import collector
from racecar_sim.cli.args import (
    MIN_RATE,
    add_driver_arguments,
    add_ros_path_options,
    add_run_options,
    add_world_arguments,
    add_xacro_arguments,
    apply_ros_path_options,
    finite_float,
    per_car,
    positive_float,
    rate_hz,
    seed_value,
    sensor_options,
    xacro_options,
)
from racecar_sim.cli.live import LiveViews, RealTimePacer, bridged, paced
from racecar_sim.cli.ros2_env import check_ros2, start_ros2_bridge
from racecar_sim.cli.ros_env import PAUSED_WAIT, check_ros, start_ros_bridge
from racecar_sim.cli.run_folder import (
    RunFolder,
    driver_label,
    early_writer,
    interrupted_note,
    node_failure_fields,
    node_failure_note,
    node_failure_title,
    output_paths,
)
from racecar_sim.cli.spawns import check_row, check_spawn_option, fleet_size
from racecar_sim.cli.terminal import StopSignals
from racecar_sim.cli.topic_map import check_topic_map, sim_drives
from racecar_sim.control.profiles import profile_names
from racecar_sim.core.errors import ConfigError, NodeError
from racecar_sim.drivers import pure_pursuit_config, wall_follow_config
from racecar_sim.physics import preset_names
from racecar_sim.runtime import Car, Simulator
from racecar_sim.runtime.driving import (
    CONSTANT_DEFAULTS,
    DRIVERS,
    attach_driver,
    driver_settings,
    is_node_spec,
    load_node_class,
)
from racecar_sim.worlds import CAR_SPACING, World, load_world, row_centerline
from racecar_sim.worlds import starting_row as fleet_spawns  # the row of `--cars N` (tests call it by this name)

if TYPE_CHECKING:
    from tqdm import tqdm

# the drivers each option applies to; an option given for another driver is an error, not silently ignored
OPTION_DRIVERS = {
    "speed": DRIVERS,
    "steering": ("constant",),
    "rate": ("constant",),
    "side": ("wall-follow",),
    "distance": ("wall-follow",),
    "path": ("pure-pursuit",),
}
PROGRESS_MIN_DURATION = 5.0  # s of sim time; shorter runs finish before a bar is worth drawing
CHUNK = 0.1  # s of sim time between progress updates
LIVE_CHUNK = 0.02  # s of sim time between viewer updates
BRIDGED_CHUNK = 0.01  # s of sim time between looks at ROS, paced to the wall clock: each /clock (100 Hz) goes out
DEFAULT_DURATION = 60.0  # s of sim time; with a ROS bridge the run goes on until Ctrl-C, as Gazebo does


def add_parser(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser(
        "run",
        help="the main job: a driver drives a world; writes runs/<time>/ (MCAP, summary.png, summary.json, camera.mp4)",
    )
    add_world_arguments(p, default_world="walker")
    wall_follow, pure_pursuit = wall_follow_config(), pure_pursuit_config()
    add_driver_arguments(p, "Default wall-follow, or constant when --steering or --rate is given or --speed is 0")
    p.add_argument(
        "--duration",
        type=positive_float,
        help=f"sim seconds to run (default {DEFAULT_DURATION:g}; with --ros or --ros2: until Ctrl-C, unless --fast)",
    )
    p.add_argument(
        "--speed",
        type=finite_float,
        help=f"m/s: the constant command (default {CONSTANT_DEFAULTS['speed']:g}; 0 stands still), or the "
        f"top speed of wall-follow (default {wall_follow.speed:g}) and pure-pursuit (default "
        f"{pure_pursuit.speed:g} where the path has no speed column)",
    )
    p.add_argument(
        "--steering",
        type=finite_float,
        help=f"rad, the constant command's steering angle (default {CONSTANT_DEFAULTS['steering']:g})",
    )
    p.add_argument(
        "--rate",
        type=rate_hz,
        help=f"Hz of the constant command (default {CONSTANT_DEFAULTS['rate']:g}; from {MIN_RATE:g} up to "
        "the physics rate)",
    )
    p.add_argument(
        "--side", choices=["right", "left"], help=f"wall-follow: the wall to follow (default {wall_follow.side})"
    )
    p.add_argument(
        "--distance",
        type=positive_float,
        help=f"wall-follow: metres to keep from the wall (default {wall_follow.distance:g})",
    )
    p.add_argument(
        "--path",
        metavar="FILE.csv",
        help="pure-pursuit: waypoint CSV (x,y[,speed]) or track centerline (default: the --world CSV)",
    )
    p.add_argument("--profile", default="seed", choices=profile_names(), help="driving profile (default seed)")
    add_xacro_arguments(p)
    add_ros_path_options(p)
    p.add_argument("--physics", default="default", choices=preset_names(), help="physics preset (default: default)")
    p.add_argument(
        "--odometry",
        default="original",
        choices=["original", "ros"],
        help="original: map->odom as the 2017 sim; ros: odom->base_link, body twist",
    )
    p.add_argument("--seed", type=seed_value, default=0, help="random seed, a whole number >= 0 (default 0)")
    p.add_argument(
        "--cars",
        type=fleet_size,
        metavar="N",
        help="a fleet of N cars named car1..carN (topics /carK/..., frames carK/...), each with its own "
        "driver: car1 at the spawn pose, each next one --car-spacing behind the one before "
        "(default: one car with the original names)",
    )
    p.add_argument(
        "--car-spacing",
        type=positive_float,
        metavar="M",
        help=f"metres between two cars in a row, along the spawn heading or a track's centerline "
        f"(default {CAR_SPACING:g}; needs --cars)",
    )
    add_run_options(
        p, default_out="runs/<date-time>, or runs/<date-time>-2... where a run started in the same second has it"
    )


def choose_drivers(args: argparse.Namespace, names: list[str]) -> list[str]:
    """Each car's driver (`names`: the cars'). `--driver X` is every car's, `--driver carK=X` car K's over it.
    Without one: constant when --steering or --rate is given (or --speed is 0: a car that stands still), else
    wall-follow. An option that applies to none of the drivers is an error."""
    given = [name for name in OPTION_DRIVERS if getattr(args, name) is not None]
    wants_constant = "steering" in given or "rate" in given or args.speed == 0
    default = "constant" if wants_constant else "wall-follow"
    drivers = [spec or default for spec in per_car(args.driver, "--driver", names, args.cars is not None)]
    for name in given:
        if not any(driver in OPTION_DRIVERS[name] for driver in drivers):
            why = "--driver" if args.driver else "the driver chosen by the other options:"
            raise ConfigError(
                f"--{name} does not apply to {why} {' or '.join(dict.fromkeys(drivers))} (it is for --driver "
                f"{' or '.join(OPTION_DRIVERS[name])})"
            )
    return drivers


def _driver_settings(args: argparse.Namespace, names: list[str], drivers: list[str]) -> list[dict[str, object]]:
    """Each car's --driver-config settings (a user's driver class loaded now, so that a bad one is one line before
    the sim is built)."""
    files = per_car(args.driver_config, "--driver-config", names, args.cars is not None)
    settings: list[dict[str, object]] = []
    for driver, path in zip(drivers, files):
        if is_node_spec(driver):
            try:
                load_node_class(driver)
            except ConfigError as exc:  # "driver X: ...": the option's own name on the CLI
                raise ConfigError(f"--{exc}") from None
        settings.append(driver_settings(path, driver) if path is not None else {})
    return settings


def _attach_driver(
    args: argparse.Namespace, sim: Simulator, car: Car, driver: str, settings: dict[str, object]
) -> object:
    """`driver` for `car`: its own instance, on the car's topics (`/carK/...` in a fleet), with the --driver-config
    settings and over them the options that apply to it."""
    if driver == "wall-follow" and car.lidar is None:
        raise ConfigError("--driver wall-follow steers by the lidar: drop --no-lidar (or DISABLE_GAZEBO_LASER)")
    if driver == "pure-pursuit" and args.path is None and "path" not in settings and not sim.world.is_track:
        raise ConfigError("--driver pure-pursuit needs --path FILE.csv (or a track .csv as --world)")
    options = {name: getattr(args, name) for name, takes in OPTION_DRIVERS.items() if driver in takes}
    params = {**settings, **{name: value for name, value in options.items() if value is not None}}
    try:
        return attach_driver(sim, car, driver, params)
    except ConfigError as exc:  # the scheduler refuses a rate above the physics rate
        if driver != "constant":
            raise
        top = 1.0 / sim.model.opt.timestep
        raise ConfigError(f"--rate: {exc} (--rate takes {MIN_RATE:g} Hz up to the physics rate, {top:g} Hz)") from None


def _simulator(args: argparse.Namespace) -> Simulator:
    """The run's Simulator: one car with the original names, or the --cars fleet."""
    common = {
        "seed": args.seed,
        "physics": args.physics,
        "sensor_noise": not args.no_noise,
        "start_line": args.start_line,
    }
    if args.cars is None:
        if args.car_spacing is not None:
            raise ConfigError("--car-spacing places a fleet: give --cars N too")
        world: str | World = args.world
        if args.spawn is not None:  # checked here, to name the option
            world = load_world(args.world, args.spawn, [Path(p) for p in args.model_path], args.wall_height)
            check_spawn_option(world, args)
        return Simulator(
            world=world,
            profile=args.profile,
            seed=args.seed,
            physics=args.physics,
            spawn=args.spawn,
            odometry=args.odometry,
            model_path=args.model_path,
            wall_height=args.wall_height,
            start_line=args.start_line,
            **sensor_options(args),
            **xacro_options(args),
        )
    world = load_world(args.world, args.spawn, [Path(p) for p in args.model_path], args.wall_height)
    spacing = CAR_SPACING if args.car_spacing is None else args.car_spacing
    spawns = fleet_spawns(world, args.cars, spacing)
    check_row(world, args, spawns, spacing, row_centerline(world))  # before N cars are built (that costs ~N²)
    sensors = sensor_options(args)
    cars = [
        Car(
            f"car{k + 1}",
            profile=args.profile,
            spawn=spawn,
            lidar=sensors["lidar"],
            camera=sensors["camera"],
            sensors_off=sensors["sensors_off"],
            odometry=args.odometry,
            **xacro_options(args),
        )
        for k, spawn in enumerate(spawns)
    ]
    return Simulator(world=world, cars=cars, **common)  # its own check: a car in a wall or another car, no ground


def _terminate(signum: int, frame: object) -> None:
    raise KeyboardInterrupt  # unwinds through the recorder's close, like Ctrl-C


def main(args: argparse.Namespace, attach: Callable[[argparse.Namespace, Simulator, Car], object] | None = None) -> int:
    """The run. `attach(args, sim, car)` puts each car's driver on (default: the --driver options; `racecar-sim
    play` gives its policy's, and sets args.driver to the name the summary shows)."""
    signal.signal(signal.SIGTERM, _terminate)
    apply_ros_path_options(args)
    driver_given = args.driver is not None
    check_topic_map(args)
    check_ros(args)
    pacing = paced(args)  # --realtime with --fast: one line, before anything is built
    if args.duration is None:  # a bridged run keeps to the wall clock until Ctrl-C, unless --fast
        args.duration = float("inf") if pacing and bridged(args) else DEFAULT_DURATION
    check_ros2(args)
    names = [f"car{k + 1}" for k in range(args.cars)] if args.cars is not None else ["racecar"]
    if attach is None:
        drivers = choose_drivers(args, names)
        settings = _driver_settings(args, names, drivers)  # a bad file or class: one line before the build
    else:
        drivers, settings = [args.driver] * len(names), [{} for _ in names]
    out, record = output_paths(args, Path("runs") / datetime.now().strftime("%Y%m%d-%H%M%S"))
    with early_writer(args, out, record), _simulator(args) as sim:
        driven = [sim_drives(args, index, driver_given) for index in range(len(sim.cars))]
        for index, (car, drive) in enumerate(zip(sim.cars, driven)):
            if not drive:
                drivers[index] = "none (ROS drives)"
            elif attach is not None:
                attach(args, sim, car)
            else:
                _attach_driver(args, sim, car, drivers[index], settings[index])
        args.driver = driver_label(sim, drivers) if any(driven) else "none (ROS drives: /drive)"
        collector.release()  # built: the collector back on for what the run makes (before a writer process starts)
        with RunFolder(args, sim, out, record) as folder, LiveViews(sim, args.viewer, args.foxglove) as live:
            wall, interrupted, failure = _drive(args, sim, live)
    if failure is not None:  # a user's node raised: the files hold the run up to that event, marked so
        folder.finish(
            node_failure_title(_title(args, sim), failure), _header(args, sim), wall, drivers,
            node_failure_fields(failure),
        )  # fmt: skip
        node_failure_note(failure)
        return NodeError.EXIT_CODE
    folder.finish(_title(args, sim), _header(args, sim), wall, drivers)
    if interrupted:
        interrupted_note(sim)
        return 130
    return 0


def _drive(args: argparse.Namespace, sim: Simulator, live: LiveViews) -> tuple[float, bool, NodeError | None]:
    """Run to --duration, until the viewer closes, until Ctrl-C / SIGTERM or until a user's node raises; returns the
    wall-clock seconds taken, whether it was interrupted and what the node raised (the run's files are written in
    every case)."""
    realtime = paced(args) or live.realtime
    chunk = BRIDGED_CHUNK if realtime and bridged(args) else LIVE_CHUNK if live.realtime else CHUNK
    endless = args.duration == float("inf")
    if endless:
        print(
            "racecar-sim: running in real time until Ctrl-C (--duration S ends it, --fast runs ahead)", file=sys.stderr
        )
    bar = _progress_bar(args.duration, endless)
    bridge = start_ros_bridge(args, sim)
    try:
        ros2 = start_ros2_bridge(args, sim)
    except BaseException:
        if bridge is not None:
            bridge.close()
        raise
    pacer = RealTimePacer()
    cameras = [car.camera for car in sim.cars if car.camera is not None]
    for camera in cameras:  # frames drawn on the GL thread while the physics goes on, published a period later
        camera.render_ahead()
    start = time.perf_counter()
    interrupted, failure = False, None
    # Ctrl-C and SIGTERM are noted and end the loop between slices: an exception raised from a signal handler can land
    # anywhere, even in a callback Python only reports ("Exception ignored in ..."). A second one still raises.
    with StopSignals((signal.SIGINT, signal.SIGTERM)) as stop:
        try:
            while sim.time < args.duration - 1e-9 and not live.closed and stop.received is None:
                sim.run_until(min(sim.time + chunk, args.duration))
                if bridge is not None:  # between events too: a paused sim still answers /gazebo/unpause_physics
                    bridge.spin_once(PAUSED_WAIT if sim.paused else 0.0)
                if ros2 is not None:
                    ros2.spin_once(PAUSED_WAIT if sim.paused else 0.0)
                live.update()
                if bar is not None:
                    bar.n = min(round(sim.time, 3), bar.total)  # never past the total: tqdm would count down below 0
                    bar.update(0)  # redraws no more often than tqdm's mininterval
                if realtime:
                    pacer.wait(sim.time)
        except KeyboardInterrupt:
            interrupted = True
        except NodeError as exc:
            failure = exc
        finally:
            for camera in cameras:
                camera.flush()  # the last frame, at the time the run stops
            if bar is not None:
                bar.close()
            if bridge is not None:
                bridge.close()
            if ros2 is not None:
                ros2.close()
    return time.perf_counter() - start, interrupted or stop.received is not None, failure


def _progress_bar(duration: float, endless: bool) -> tqdm | None:
    """The progress bar on stderr (a terminal's only), or None where none is drawn: an endless run, or one too short
    for a bar to be worth drawing (tqdm is then never imported: start-up)."""
    if endless or duration < PROGRESS_MIN_DURATION:
        return None
    from tqdm import tqdm

    return tqdm(
        total=round(duration, 3),
        unit="sim s",
        disable=None,
        bar_format="{l_bar}{bar}| {n:.1f}/{total:.1f} sim s [{elapsed}<{remaining}]",
        file=sys.stderr,
    )


def _title(args: argparse.Namespace, sim: Simulator) -> str:
    fleet = f"{len(sim.cars)} cars, " if args.cars is not None else ""
    return f"{sim.world.name}: {fleet}{args.driver}, {sim.time:.0f} s sim, seed {sim.seed}"


def _header(args: argparse.Namespace, sim: Simulator) -> list[str]:
    """The printed summary's first lines: the world, the drivers, the profile, the physics, the seed (and the fleet)."""
    lines = [
        f"world {sim.world.name}, driver {args.driver}, profile {sim.car.profile.name}, physics {sim.preset.name} "
        f"(step {sim.model.opt.timestep * 1e3:g} ms), seed {sim.seed}"
    ]
    if args.cars is not None:
        spacing = CAR_SPACING if args.car_spacing is None else args.car_spacing
        lines.append(
            f"cars             {len(sim.cars)} ({sim.cars[0].model_name}..{sim.cars[-1].model_name}), "
            f"{spacing:g} m apart"
        )
    return lines
