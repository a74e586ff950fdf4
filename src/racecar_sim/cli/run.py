"""`racecar-sim run`: the main job. A driver drives the car in a world; the run leaves a folder to look at.

With no arguments: wall-follow round the `walker` racecourse for 60 s of sim time with the lidar and the
camera on, then runs/<timestamp>/ holds run.mcap, summary.png and camera.mp4, and a summary is printed.
"""

from __future__ import annotations

import argparse
import os
import signal
import sys
import time
from datetime import datetime
from pathlib import Path

from tqdm import tqdm

from racecar_sim.cli.args import (add_sensor_arguments, add_world_arguments, check_folder, check_record_path,
                                  finite_float, make_folder, positive_float, seed_value, sensor_options)
from racecar_sim.cli.live import LiveViews, RealTimePacer, add_live_arguments
from racecar_sim.control.profiles import profile_names
from racecar_sim.core.errors import ConfigError
from racecar_sim.description.vehicle import VehicleGeometry
from racecar_sim.drivers import (ConstantCommand, PurePursuit, WallFollower, load_waypoints, pure_pursuit_config,
                                 wall_follow_config)
from racecar_sim.physics import preset_names
from racecar_sim.runtime import Simulator
from racecar_sim.runtime.run_log import RunLog, image_array

DRIVERS = ("wall-follow", "pure-pursuit", "constant")
CONSTANT_DEFAULTS = {"speed": 1.0, "steering": 0.0, "rate": 20.0}
# the drivers each option applies to; an option given for another driver is an error, not silently ignored
OPTION_DRIVERS = {"speed": DRIVERS, "steering": ("constant",), "rate": ("constant",), "side": ("wall-follow",),
                  "distance": ("wall-follow",), "path": ("pure-pursuit",)}
PROGRESS_MIN_DURATION = 5.0  # s of sim time; shorter runs finish before a bar is worth drawing
CHUNK = 0.1  # s of sim time between progress updates
LIVE_CHUNK = 0.02  # s of sim time between viewer updates


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("run", help="the main job: a driver drives a world; writes runs/<time>/ (MCAP, summary.png, "
                                   "camera.mp4)")
    add_world_arguments(p, default_world="walker")
    wall_follow, pure_pursuit = wall_follow_config(), pure_pursuit_config()
    p.add_argument("--driver", choices=DRIVERS,
                   help="wall-follow (lidar PID), pure-pursuit (a path CSV), constant (--speed/--steering); default "
                        "wall-follow, or constant when --steering or --rate is given or --speed is 0")
    p.add_argument("--duration", type=positive_float, default=60.0, help="sim seconds to run (default 60)")
    p.add_argument("--speed", type=finite_float,
                   help=f"m/s: the constant command (default {CONSTANT_DEFAULTS['speed']:g}; 0 stands still), or the "
                        f"top speed of wall-follow (default {wall_follow.speed:g}) and pure-pursuit (default "
                        f"{pure_pursuit.speed:g} where the path has no speed column)")
    p.add_argument("--steering", type=finite_float,
                   help=f"rad, the constant command's steering angle (default {CONSTANT_DEFAULTS['steering']:g})")
    p.add_argument("--rate", type=positive_float,
                   help=f"Hz of the constant command (default {CONSTANT_DEFAULTS['rate']:g}; at most the physics rate)")
    p.add_argument("--side", choices=["right", "left"], help=f"wall-follow: the wall to follow (default {wall_follow.side})")
    p.add_argument("--distance", type=positive_float,
                   help=f"wall-follow: metres to keep from the wall (default {wall_follow.distance:g})")
    p.add_argument("--path", metavar="FILE.csv",
                   help="pure-pursuit: waypoint CSV (x,y[,speed]) or track centerline (default: the --world CSV)")
    p.add_argument("--profile", default="seed", choices=profile_names(), help="driving profile (default seed)")
    p.add_argument("--physics", default="default", choices=preset_names(), help="physics preset (default: default)")
    p.add_argument("--odometry", default="original", choices=["original", "ros"],
                   help="original: map->odom as the 2017 sim; ros: odom->base_link, body twist")
    p.add_argument("--seed", type=seed_value, default=0, help="random seed, a whole number >= 0 (default 0)")
    p.add_argument("--out", metavar="DIR", help="folder for the run's files (default runs/<date-time>)")
    p.add_argument("--record", metavar="FILE.mcap", help="the MCAP's path (default OUT/run.mcap)")
    p.add_argument("--no-record", action="store_true", help="no MCAP recording")
    p.add_argument("--no-video", action="store_true", help="no camera.mp4")
    p.add_argument("--no-summary", action="store_true", help="no summary.png")
    add_sensor_arguments(p)
    add_live_arguments(p)
    p.add_argument("--realtime", action="store_true", help="run no faster than real time")


def choose_driver(args: argparse.Namespace) -> str:
    """The driver the options ask for. Without --driver: constant when --steering or --rate is given (or --speed
    is 0: a car that stands still), else wall-follow. An option that does not apply to it is an error."""
    given = [name for name in OPTION_DRIVERS if getattr(args, name) is not None]
    driver = args.driver
    if driver is None:
        wants_constant = "steering" in given or "rate" in given or args.speed == 0
        driver = "constant" if wants_constant else "wall-follow"
    for name in given:
        if driver not in OPTION_DRIVERS[name]:
            why = "--driver" if args.driver else "the driver chosen by the other options:"
            raise ConfigError(f"--{name} does not apply to {why} {driver} (it is for --driver "
                              f"{' or '.join(OPTION_DRIVERS[name])})")
    return driver


def _attach_driver(args: argparse.Namespace, sim: Simulator) -> object:
    if args.driver == "constant":
        options = {k: default if getattr(args, k) is None else getattr(args, k) for k, default in CONSTANT_DEFAULTS.items()}
        try:
            return ConstantCommand(sim.bus, sim.scheduler, options["speed"], options["steering"], options["rate"])
        except ConfigError as exc:  # the scheduler refuses a rate above the physics rate
            raise ConfigError(f"--rate: {exc}") from None
    if args.driver == "wall-follow":
        if sim.lidar is None:
            raise ConfigError("--driver wall-follow steers by the lidar: drop --no-lidar (or DISABLE_GAZEBO_LASER)")
        return WallFollower(sim.bus, wall_follow_config(side=args.side, distance=args.distance, speed=args.speed))
    path = args.path or (args.world if str(args.world).endswith(".csv") else None)
    if path is None:
        raise ConfigError("--driver pure-pursuit needs --path FILE.csv (or a track .csv as --world)")
    wheelbase = VehicleGeometry.from_robot(sim.robot).wheelbase  # the loaded xacro's, not the YAML's default
    return PurePursuit(sim.bus, load_waypoints(path), pure_pursuit_config(speed=args.speed, wheelbase=wheelbase))


def _output_paths(args: argparse.Namespace) -> tuple[Path, Path | None]:
    """The run's folder and the MCAP path, checked before the sim is built: a bad --out or --record is one line,
    never a traceback after a minute of simulation."""
    out = Path(args.out) if args.out else Path("runs") / datetime.now().strftime("%Y%m%d-%H%M%S")
    record = None if args.no_record else Path(args.record) if args.record else out / "run.mcap"
    check_folder("--out", out)
    if record is not None:
        check_record_path(record)
    return out, record


def _terminate(signum: int, frame: object) -> None:
    raise KeyboardInterrupt  # unwinds through the recorder's close, like Ctrl-C


def main(args: argparse.Namespace) -> int:
    signal.signal(signal.SIGTERM, _terminate)
    args.driver = choose_driver(args)
    out, record = _output_paths(args)
    with Simulator(world=args.world, profile=args.profile, seed=args.seed, physics=args.physics, spawn=args.spawn,
                   odometry=args.odometry, model_path=args.model_path, wall_height=args.wall_height,
                   **sensor_options(args)) as sim:
        _attach_driver(args, sim)
        if not args.no_summary or (sim.camera is not None and not args.no_video):
            make_folder("--out", out)
        if record is not None:
            make_folder("--record", record.parent)
            sim.record(record)
        runlog = RunLog(sim.bus, sim.lidar.topic if sim.lidar else None,
                        sim.camera.spec.image_topic if sim.camera else None)
        video = _video(args, sim, out)
        written: list[Path] = [record] if record is not None else []
        try:
            with LiveViews(sim, args.viewer, args.foxglove) as live:
                wall, interrupted = _drive(args, sim, live)
        finally:
            if video is not None and video.frames:
                written.append(video.close())
        if sim.lidar is not None and runlog.last_scan is not None:
            origin, ends = sim.lidar.beam_ends(runlog.last_scan.ranges)
        else:
            origin = ends = None
    if not args.no_summary:
        from racecar_sim.plots.summary import save_summary  # matplotlib loads only when a summary is drawn

        lines = _summary_lines(sim, runlog, wall)
        written.insert(0, save_summary(out / "summary.png", sim.world, runlog.trajectory,
                                       scan_origin=None if origin is None else origin[:2],
                                       scan_points=None if ends is None else ends[:, :2],
                                       camera_bgr=runlog.last_frame(), title=_title(args, sim), lines=lines))
    _print_summary(args, sim, runlog, wall, written)
    if interrupted:
        print(f"racecar-sim: interrupted at sim time {sim.time:.2f} s; the files above are complete", file=sys.stderr)
        return 130
    return 0


def _video(args: argparse.Namespace, sim: Simulator, out: Path) -> object:
    if args.no_video or sim.camera is None:
        return None
    from racecar_sim.recording.video import VideoWriter  # PyAV loads only when a video is written

    spec = sim.camera.spec
    video = VideoWriter(out / "camera.mp4", spec.rate_hz, spec.width, spec.height)
    sim.subscribe(spec.image_topic, lambda msg: video.write(image_array(msg)))
    return video


def _drive(args: argparse.Namespace, sim: Simulator, live: LiveViews) -> tuple[float, bool]:
    """Run to --duration, until the viewer closes or until Ctrl-C / SIGTERM; returns the wall-clock seconds
    taken and whether it was interrupted (the run's files are written either way)."""
    realtime = args.realtime or live.realtime
    chunk = LIVE_CHUNK if live.realtime else CHUNK
    bar = tqdm(total=round(args.duration, 3), unit="sim s", disable=args.duration < PROGRESS_MIN_DURATION or None,
               bar_format="{l_bar}{bar}| {n:.1f}/{total:.1f} sim s [{elapsed}<{remaining}]", file=sys.stderr)
    pacer = RealTimePacer()
    start = time.perf_counter()
    interrupted = False
    try:
        while sim.time < args.duration - 1e-9 and not live.closed:
            sim.run_until(min(sim.time + chunk, args.duration))
            live.update()
            bar.n = min(round(sim.time, 3), bar.total)  # never past the total: tqdm would warn and count down below 0
            bar.update(0)  # redraws no more often than tqdm's mininterval
            if realtime:
                pacer.wait(sim.time)
    except KeyboardInterrupt:
        interrupted = True
    finally:
        bar.close()
    return time.perf_counter() - start, interrupted


def _title(args: argparse.Namespace, sim: Simulator) -> str:
    return f"{sim.world.name}: {args.driver}, {sim.time:.0f} s sim, seed {sim.seed}"


def _summary_lines(sim: Simulator, runlog: RunLog, wall: float) -> list[str]:
    lines = [f"distance         {runlog.distance:.1f} m",
             f"mean speed       {runlog.mean_speed:.2f} m/s",
             f"real-time factor {sim.time / max(wall, 1e-9):.1f}x"]
    if runlog.last_scan is not None:
        lines.append(f"min clearance    {runlog.min_clearance:.2f} m (lidar)")
    return lines


def _print_summary(args: argparse.Namespace, sim: Simulator, runlog: RunLog, wall: float, written: list[Path]) -> None:
    print(f"world {sim.world.name}, driver {args.driver}, profile {sim.profile.name}, physics {sim.preset.name} "
          f"(step {sim.model.opt.timestep * 1e3:g} ms), seed {sim.seed}")
    print(f"sim time         {sim.time:.2f} s")
    for line in _summary_lines(sim, runlog, wall):
        print(line)
    trajectory = runlog.trajectory
    if len(trajectory) and runlog.last_pose is not None:
        x, y, yaw = runlog.last_pose
        print(f"final pose       x {x:.3f} m, y {y:.3f} m, yaw {yaw:.3f} rad")
    for path in written:
        print(f"wrote            {path}")
