"""`racecar-sim run`: the main job. A driver drives the car in a world; the run leaves a folder to look at.

With no arguments: wall-follow round the `walker` racecourse for 60 s of sim time with the lidar and the
camera on, then runs/<timestamp>/ holds run.mcap, summary.png and camera.mp4, and a summary is printed.

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
from datetime import datetime
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from tqdm import tqdm

from racecar_sim.cli.args import (
    MIN_RATE,
    add_overwrite_argument,
    add_ros_path_options,
    add_sensor_arguments,
    add_world_arguments,
    add_xacro_arguments,
    apply_ros_path_options,
    check_folder,
    check_record_path,
    finite_float,
    fresh_folder,
    make_folder,
    positive_float,
    rate_hz,
    seed_value,
    sensor_options,
    xacro_options,
)
from racecar_sim.cli.live import LiveViews, RealTimePacer, add_live_arguments
from racecar_sim.cli.ros_env import PAUSED_WAIT, add_ros_arguments, check_ros, start_ros_bridge
from racecar_sim.cli.spawns import check_row, check_spawn_option, fleet_size
from racecar_sim.control.profiles import profile_names
from racecar_sim.core.errors import ConfigError, RecordingError
from racecar_sim.core.names import ODOM
from racecar_sim.drivers import pure_pursuit_config, wall_follow_config
from racecar_sim.physics import preset_names
from racecar_sim.runtime import Car, Simulator
from racecar_sim.runtime.driving import CONSTANT_DEFAULTS, DRIVERS, attach_driver
from racecar_sim.runtime.run_log import RunLog, image_array
from racecar_sim.worlds import CAR_SPACING, World, load_world, row_centerline
from racecar_sim.worlds import starting_row as fleet_spawns  # the row of `--cars N` (tests call it by this name)

if TYPE_CHECKING:  # mcap, Pillow and PyAV load only when a run needs them
    from racecar_sim.recording.run_recording import RunRecording
    from racecar_sim.recording.video import VideoWriter
    from racecar_sim.recording.writer_process import ProcessVideo

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


def add_parser(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser(
        "run", help="the main job: a driver drives a world; writes runs/<time>/ (MCAP, summary.png, camera.mp4)"
    )
    add_world_arguments(p, default_world="walker")
    wall_follow, pure_pursuit = wall_follow_config(), pure_pursuit_config()
    p.add_argument(
        "--driver",
        choices=DRIVERS,
        help="wall-follow (lidar PID), pure-pursuit (a path CSV), constant (--speed/--steering); default "
        "wall-follow, or constant when --steering or --rate is given or --speed is 0",
    )
    p.add_argument("--duration", type=positive_float, default=60.0, help="sim seconds to run (default 60)")
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
        "--out",
        metavar="DIR",
        help="folder for the run's files (default runs/<date-time>, or "
        "runs/<date-time>-2... where a run started in the same second has it)",
    )
    p.add_argument("--record", metavar="FILE.mcap", help="the MCAP's path (default OUT/run.mcap)")
    add_overwrite_argument(p)
    p.add_argument("--no-record", action="store_true", help="no MCAP recording")
    p.add_argument(
        "--raw-images",
        action="store_true",
        help="record camera images as raw sensor_msgs/Image on the image topic (default: JPEG "
        "sensor_msgs/CompressedImage on <image topic>/compressed, as image_transport records them)",
    )
    p.add_argument("--no-video", action="store_true", help="no camera.mp4")
    p.add_argument("--no-summary", action="store_true", help="no summary.png")
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
    add_sensor_arguments(p)
    add_live_arguments(p)
    p.add_argument("--realtime", action="store_true", help="run no faster than real time")
    add_ros_arguments(p)


def choose_driver(args: argparse.Namespace) -> str:
    """The driver the options ask for. Without --driver: constant when --steering or --rate is given (or --speed
    is 0: a car that stands still), else wall-follow. An option that does not apply to it is an error."""
    given = [name for name in OPTION_DRIVERS if getattr(args, name) is not None]
    driver: str | None = args.driver
    if driver is None:
        wants_constant = "steering" in given or "rate" in given or args.speed == 0
        driver = "constant" if wants_constant else "wall-follow"
    for name in given:
        if driver not in OPTION_DRIVERS[name]:
            why = "--driver" if args.driver else "the driver chosen by the other options:"
            raise ConfigError(
                f"--{name} does not apply to {why} {driver} (it is for --driver {' or '.join(OPTION_DRIVERS[name])})"
            )
    return driver


def _attach_driver(args: argparse.Namespace, sim: Simulator, car: Car) -> object:
    """The run's driver for `car`: its own instance, on the car's topics (`/carK/...` in a fleet)."""
    if args.driver == "wall-follow" and car.lidar is None:
        raise ConfigError("--driver wall-follow steers by the lidar: drop --no-lidar (or DISABLE_GAZEBO_LASER)")
    if args.driver == "pure-pursuit" and args.path is None and not sim.world.is_track:
        raise ConfigError("--driver pure-pursuit needs --path FILE.csv (or a track .csv as --world)")
    params = {name: getattr(args, name) for name, drivers in OPTION_DRIVERS.items() if args.driver in drivers}
    try:
        return attach_driver(sim, car, args.driver, params)
    except ConfigError as exc:  # the scheduler refuses a rate above the physics rate
        if args.driver != "constant":
            raise
        top = 1.0 / sim.model.opt.timestep
        raise ConfigError(f"--rate: {exc} (--rate takes {MIN_RATE:g} Hz up to the physics rate, {top:g} Hz)") from None


def _simulator(args: argparse.Namespace) -> Simulator:
    """The run's Simulator: one car with the original names, or the --cars fleet."""
    common = {"seed": args.seed, "physics": args.physics, "sensor_noise": not args.no_noise}
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


def _output_paths(args: argparse.Namespace) -> tuple[Path, Path | None]:
    """The run's folder and the MCAP path, checked before the sim is built: a bad --out or --record is one line,
    never a traceback after a minute of simulation."""
    out = Path(args.out) if args.out else Path("runs") / datetime.now().strftime("%Y%m%d-%H%M%S")
    record = None if args.no_record else Path(args.record) if args.record else out / "run.mcap"
    check_folder("--out", out)
    if args.raw_images and record is None:
        raise ConfigError("--raw-images says how camera images are recorded: drop --no-record")
    if record is not None:  # in the default folder: that is a fresh one (_run_folder)
        check_record_path(record, overwrite=args.overwrite or (args.out is None and args.record is None))
    return out, record


def _run_folder(args: argparse.Namespace, out: Path, record: Path | None, files: bool) -> tuple[Path, Path | None]:
    """Make the run's folder where it gets `files` (summary, video) or the recording: the default runs/<date-time>
    is a fresh folder (runs/<date-time>-2 if another run has that one), so no two runs share it."""
    default_record = record is not None and args.record is None
    if args.out is None and (files or default_record):
        out = fresh_folder("--out", out)
        return out, out / "run.mcap" if default_record else record
    if files:
        make_folder("--out", out)
    return out, record


def _terminate(signum: int, frame: object) -> None:
    raise KeyboardInterrupt  # unwinds through the recorder's close, like Ctrl-C


def main(args: argparse.Namespace) -> int:
    signal.signal(signal.SIGTERM, _terminate)
    apply_ros_path_options(args)
    args.driver = choose_driver(args)
    check_ros(args)
    out, record = _output_paths(args)
    with _simulator(args) as sim:
        for car in sim.cars:
            _attach_driver(args, sim, car)
        out, record = _run_folder(
            args, out, record, files=not args.no_summary or (sim.car.camera is not None and not args.no_video)
        )
        recording = _recording(args, sim, record)
        try:
            runlogs = [
                RunLog(
                    sim.bus,
                    car.lidar.topic if car.lidar else None,
                    car.camera.spec.image_topic if car.camera and i == 0 else None,
                    odom_topic=car.topic(ODOM),
                )
                for i, car in enumerate(sim.cars)
            ]
            runlog = runlogs[0]
            video = _video(args, sim, out, recording)
            written: list[Path] = [record] if record is not None else []
            try:
                with LiveViews(sim, args.viewer, args.foxglove) as live:
                    wall, interrupted = _drive(args, sim, live)
            finally:
                if video is not None:
                    video_path = video.close()
                    if video.frames:
                        written.append(video_path)
        finally:
            if recording is not None:
                recording.close()  # writes what the writer process still holds, then the summary and footer
        origin: np.ndarray | None
        ends: np.ndarray | None
        if sim.car.lidar is not None and runlog.last_scan is not None:
            origin, ends = sim.car.lidar.beam_ends(runlog.last_scan.ranges)
        else:
            origin = ends = None
    if not args.no_summary:
        from racecar_sim.plots.summary import save_summary  # matplotlib loads only when a summary is drawn

        lines = _summary_lines(sim, runlogs, wall)
        paths = (
            runlog.trajectory
            if args.cars is None
            else {car.model_name: log.trajectory for car, log in zip(sim.cars, runlogs)}
        )
        written.insert(
            0,
            save_summary(
                out / "summary.png",
                sim.world,
                paths,
                scan_origin=None if origin is None else origin[:2],
                scan_points=None if ends is None else ends[:, :2],
                camera_bgr=runlog.last_frame(),
                title=_title(args, sim),
                lines=lines,
                rate=runlog.trajectory_rate,
            ),
        )
    _print_summary(args, sim, runlogs, wall, written)
    if interrupted:
        print(f"racecar-sim: interrupted at sim time {sim.time:.2f} s; the files above are complete", file=sys.stderr)
        return 130
    return 0


def _recording(args: argparse.Namespace, sim: Simulator, record: Path | None) -> RunRecording | None:
    """The run's MCAP, written by a writer process; camera images as JPEG CompressedImage unless --raw-images."""
    if record is None:
        return None
    from racecar_sim.recording.run_recording import RunRecording  # mcap and Pillow load only when a run records

    make_folder("--record", record.parent)
    image_topics = [car.camera.spec.image_topic for car in sim.cars if car.camera is not None]
    try:
        return RunRecording(
            sim.bus,
            lambda: sim.time_ns,
            record,
            image_topics=image_topics,
            raw_images=args.raw_images,
            overwrite=args.overwrite,
        )
    except RecordingError as exc:  # taken by another run since the look before the build, or cannot be created
        raise RecordingError(f"--record {exc}") from None


def _video(
    args: argparse.Namespace, sim: Simulator, out: Path, recording: RunRecording | None
) -> VideoWriter | ProcessVideo | None:
    """camera.mp4, encoded by the recording's writer process (each frame crosses to it once), by a process of its
    own without a recording, or on a writer thread where no process can start."""
    if args.no_video or sim.car.camera is None:
        return None
    from racecar_sim.recording.writer_process import ProcessVideo, WriterProcess

    spec = sim.car.camera.spec
    path = out / "camera.mp4"
    process = getattr(recording, "process", None)
    owns = process is None
    if owns:
        try:
            process = WriterProcess(f"video {path}")
        except OSError:
            process = None
    if process is None:
        from racecar_sim.recording.video import VideoWriter  # PyAV loads only when a video is written

        writer = VideoWriter(path, spec.rate_hz, spec.width, spec.height, background=True)
        sim.subscribe(spec.image_topic, lambda msg: writer.write(image_array(msg)))
        return writer
    video = ProcessVideo(process, path, spec.rate_hz, spec.width, spec.height, owns_process=owns)
    sim.subscribe(spec.image_topic, video.write_image)
    return video


def _drive(args: argparse.Namespace, sim: Simulator, live: LiveViews) -> tuple[float, bool]:
    """Run to --duration, until the viewer closes or until Ctrl-C / SIGTERM; returns the wall-clock seconds
    taken and whether it was interrupted (the run's files are written either way)."""
    realtime = args.realtime or live.realtime
    chunk = LIVE_CHUNK if live.realtime else CHUNK
    bar = tqdm(
        total=round(args.duration, 3),
        unit="sim s",
        disable=args.duration < PROGRESS_MIN_DURATION or None,
        bar_format="{l_bar}{bar}| {n:.1f}/{total:.1f} sim s [{elapsed}<{remaining}]",
        file=sys.stderr,
    )
    bridge = start_ros_bridge(args, sim)
    pacer = RealTimePacer()
    cameras = [car.camera for car in sim.cars if car.camera is not None]
    for camera in cameras:  # frames drawn on the GL thread while the physics goes on, published a period later
        camera.render_ahead()
    start = time.perf_counter()
    interrupted = False
    try:
        while sim.time < args.duration - 1e-9 and not live.closed:
            sim.run_until(min(sim.time + chunk, args.duration))
            if bridge is not None:  # between events too: a paused sim still answers /gazebo/unpause_physics
                bridge.spin_once(PAUSED_WAIT if sim.paused else 0.0)
            live.update()
            bar.n = min(round(sim.time, 3), bar.total)  # never past the total: tqdm would warn and count down below 0
            bar.update(0)  # redraws no more often than tqdm's mininterval
            if realtime:
                pacer.wait(sim.time)
    except KeyboardInterrupt:
        interrupted = True
    finally:
        for camera in cameras:
            camera.flush()  # the last frame, at the time the run stops
        bar.close()
        if bridge is not None:
            bridge.close()
    return time.perf_counter() - start, interrupted


def _title(args: argparse.Namespace, sim: Simulator) -> str:
    fleet = f"{len(sim.cars)} cars, " if args.cars is not None else ""
    return f"{sim.world.name}: {fleet}{args.driver}, {sim.time:.0f} s sim, seed {sim.seed}"


def _summary_lines(sim: Simulator, runlogs: list[RunLog], wall: float) -> list[str]:
    """The summary's numbers: the single car's as always, or a row per car of a fleet."""
    rtf = f"real-time factor {sim.time / max(wall, 1e-9):.1f}x"
    if not sim.cars[0].name:
        runlog = runlogs[0]
        lines = [f"distance         {runlog.distance:.1f} m", f"mean speed       {runlog.mean_speed:.2f} m/s", rtf]
        if runlog.last_scan is not None:
            lines.append(f"min clearance    {runlog.min_clearance:.2f} m (lidar)")
        return lines
    lines = [rtf, f"{'car':<6}{'distance':>10}{'mean speed':>12}{'min clearance':>15}"]
    for car, log in zip(sim.cars, runlogs):
        clearance = f"{log.min_clearance:.2f} m" if log.last_scan is not None else "-"
        lines.append(f"{car.model_name:<6}{log.distance:>8.1f} m{log.mean_speed:>8.2f} m/s{clearance:>15}")
    return lines


def _print_summary(
    args: argparse.Namespace, sim: Simulator, runlogs: list[RunLog], wall: float, written: list[Path]
) -> None:
    print(
        f"world {sim.world.name}, driver {args.driver}, profile {sim.car.profile.name}, physics {sim.preset.name} "
        f"(step {sim.model.opt.timestep * 1e3:g} ms), seed {sim.seed}"
    )
    if args.cars is not None:
        spacing = CAR_SPACING if args.car_spacing is None else args.car_spacing
        print(
            f"cars             {len(sim.cars)} ({sim.cars[0].model_name}..{sim.cars[-1].model_name}), "
            f"{spacing:g} m apart"
        )
    print(f"sim time         {sim.time:.2f} s")
    for line in _summary_lines(sim, runlogs, wall):
        print(line)
    if args.cars is None:
        runlog = runlogs[0]
        if len(runlog.trajectory) and runlog.last_pose is not None:
            x, y, yaw = runlog.last_pose
            print(f"final pose       x {x:.3f} m, y {y:.3f} m, yaw {yaw:.3f} rad")
    else:
        for car, log in zip(sim.cars, runlogs):
            if log.last_pose is not None:
                x, y, yaw = log.last_pose
                print(f"{car.model_name + ' final pose':<17}x {x:.3f} m, y {y:.3f} m, yaw {yaw:.3f} rad")
    for path in written:
        print(f"wrote            {path}")
