"""argparse types that reject bad values with a one-line message (argparse exits 2)."""

from __future__ import annotations

import argparse
import itertools
import math
import os
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any, TypedDict

from racecar_sim.core.errors import ConfigError
from racecar_sim.description.ros_packages import add_model_path, add_package_path
from racecar_sim.description.vehicle_params import VehicleParams, load_vehicle
from racecar_sim.worlds import DEFAULT_WALL_HEIGHT, Spawn
from racecar_sim.worlds.world import MAX_COORDINATE

_ARG_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_\-]*")
# Hz: the slowest timer rate; the scheduler keeps a rate as a fraction with a denominator up to 1e6 (1e-300 Hz
# became Fraction(1, 0))
MIN_RATE = 1e-6


def finite_float(text: str) -> float:
    """A float that is not NaN or infinite."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"'{text}' is not a number") from None
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"'{text}' is not a finite number")
    return value


def positive_float(text: str) -> float:
    """A finite float > 0."""
    value = finite_float(text)
    if value <= 0:
        raise argparse.ArgumentTypeError(f"'{text}' must be positive")
    return value


def rate_hz(text: str) -> float:
    """A rate in Hz the scheduler can keep: from MIN_RATE up (the physics rate, the top, is checked once the
    physics step is known)."""
    value = finite_float(text)
    if not value >= MIN_RATE:
        from racecar_sim.physics.presets import load_preset  # only for the message

        top = 1.0 / load_preset("default").timestep
        raise argparse.ArgumentTypeError(
            f"'{text}' Hz is outside the rates a timer keeps: from {MIN_RATE:g} Hz up to "
            f"the physics rate ({top:g} Hz with --physics default)"
        )
    return value


def _whole_number(text: str, minimum: int) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"'{text}' is not a whole number") from None
    if value < minimum:
        raise argparse.ArgumentTypeError(f"'{text}' must be {minimum} or more")
    return value


def positive_int(text: str) -> int:
    """A whole number >= 1."""
    return _whole_number(text, 1)


def seed_value(text: str) -> int:
    """A random seed: a whole number >= 0 (numpy takes no negative seeds)."""
    return _whole_number(text, 0)


def spawn_pose(text: str) -> Spawn:
    """'x,y,yaw' (or 'x,y,z,yaw')."""
    parts = text.split(",")
    if len(parts) not in (3, 4):
        raise argparse.ArgumentTypeError(f"'{text}' is not x,y,yaw or x,y,z,yaw")
    values = [finite_float(p) for p in parts]
    for name, value in zip(("x", "y") if len(values) == 3 else ("x", "y", "z"), values):
        if abs(value) > MAX_COORDINATE:
            raise argparse.ArgumentTypeError(
                f"'{text}': {name} {value:g} m is beyond the largest world coordinate (±{MAX_COORDINATE:g} m)"
            )
    if len(values) == 3:
        return Spawn(values[0], values[1], Spawn().z, values[2])
    return Spawn(*values)


def xacro_arg(text: str) -> tuple[str, str]:
    """'name:=value', as on the xacro command line (the name a xacro/roslaunch argument name)."""
    name, sep, value = text.partition(":=")
    if not sep:
        raise argparse.ArgumentTypeError(f"'{text}' is not name:=value")
    if not _ARG_NAME.fullmatch(name):
        raise argparse.ArgumentTypeError(
            f"'{text}': '{name}' is not an argument name (letters, digits, _ and -, not starting with a digit)"
        )
    return name, value


def add_xacro_arguments(p: argparse.ArgumentParser) -> None:
    """--xacro FILE and --xacro-arg NAME:=VALUE: the user's own car."""
    p.add_argument(
        "--xacro",
        metavar="FILE",
        help="the car's xacro or URDF file, e.g. a description package's "
        "(default: the shipped racecar.xacro); $(find pkg) and package:// "
        "go through --package-path and ROS_PACKAGE_PATH",
    )
    p.add_argument(
        "--xacro-arg",
        dest="xacro_args",
        type=xacro_arg,
        action="append",
        default=[],
        metavar="NAME:=VALUE",
        help="xacro argument of the car, repeatable (over the profile's own)",
    )
    add_vehicle_argument(p)


def add_vehicle_argument(p: argparse.ArgumentParser) -> None:
    """--vehicle NAME|FILE.yaml: the car's tyre and actuator parameter set."""
    p.add_argument(
        "--vehicle",
        type=vehicle_set,
        default=None,
        metavar="NAME|FILE.yaml",
        help="tyre and actuator parameters: seed (default, no tyre model), f1tenth, or a YAML file in F1TENTH's names",
    )


def vehicle_set(text: str) -> VehicleParams:
    """A vehicle set by name or YAML file, read now so that a bad one is a one-line usage error."""
    try:
        return load_vehicle(text)
    except ConfigError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


class XacroOptions(TypedDict, total=False):
    """Car / Simulator keyword arguments for the car's description."""

    xacro: Path
    xacro_args: dict[str, str]
    vehicle: VehicleParams


def xacro_options(args: argparse.Namespace) -> XacroOptions:
    """Car / Simulator keyword arguments from --xacro and --xacro-arg (none when not given)."""
    options: XacroOptions = {}
    if args.xacro is not None:
        options["xacro"] = Path(args.xacro)
    if args.xacro_args:
        options["xacro_args"] = dict(args.xacro_args)
    if getattr(args, "vehicle", None) is not None:
        options["vehicle"] = args.vehicle
    return options


def add_ros_path_options(p: argparse.ArgumentParser) -> None:
    """--package-path DIR (repeatable): folders of ROS packages, searched before ROS_PACKAGE_PATH."""
    p.add_argument(
        "--package-path",
        action="append",
        default=[],
        metavar="DIR",
        help="folder holding ROS packages (package.xml), searched before ROS_PACKAGE_PATH for $(find pkg), "
        "package:// and, with the folders holding them, model:// (repeatable)",
    )


def apply_ros_path_options(args: argparse.Namespace) -> None:
    """Put --package-path (and --model-path) first on ROS_PACKAGE_PATH (GAZEBO_MODEL_PATH), for this process and
    the ROS processes it starts; ConfigError for a folder that does not exist."""
    add_package_path(getattr(args, "package_path", None) or [])
    model_dirs = getattr(args, "model_path", None) or []
    for folder in model_dirs:
        if not Path(folder).is_dir():
            raise ConfigError(
                f"--model-path {folder}: no such folder (give a folder that holds model:// models, "
                "each a folder with its model.config)"
            )
    add_model_path(model_dirs)


def add_world_arguments(p: argparse.ArgumentParser, world_option: bool = True, default_world: str = "empty") -> None:
    """--world, --spawn, --model-path and --wall-height, shared by the subcommands that load a world."""
    if world_option:
        p.add_argument(
            "--world",
            default=default_world,
            metavar="NAME|PATH",
            help="built-in world (see `racecar-sim worlds`), SDF .world/.sdf file, ROS map .yaml, "
            f"or race-track centerline .csv (default: {default_world})",
        )
    p.add_argument(
        "--spawn",
        type=spawn_pose,
        help="spawn pose x,y,yaw or x,y,z,yaw (default: the world's own); "
        "checked against the world: inside an obstacle or over nothing "
        "is an error",
    )
    p.add_argument(
        "--model-path",
        action="append",
        default=[],
        metavar="DIR",
        help="folder holding model:// models, searched before GAZEBO_MODEL_PATH (repeatable)",
    )
    p.add_argument(
        "--wall-height",
        type=positive_float,
        default=DEFAULT_WALL_HEIGHT,
        metavar="M",
        help=f"height of walls extruded from a map or track file (default {DEFAULT_WALL_HEIGHT:g} m)",
    )


def add_sensor_arguments(p: argparse.ArgumentParser) -> None:
    """--no-lidar, --no-camera, --no-sensor and --no-noise (DISABLE_GAZEBO_LASER / DISABLE_GAZEBO_CAMERA=true work
    too): the sensor switches of runtime/plugins.py."""
    p.add_argument("--no-lidar", action="store_true", help="no lasers (/scan: the Hokuyo is not simulated)")
    p.add_argument(
        "--no-camera",
        action="store_true",
        help="no cameras, depth cameras included (/camera/zed images; no OpenGL needed)",
    )
    p.add_argument(
        "--no-sensor",
        action="append",
        default=[],
        metavar="NAME",
        help="leave out the description's sensors of a switch (lidar, camera, imu), a sensor type "
        "(depth) or a sensor's own name (rear_hokuyo); repeatable",
    )
    p.add_argument("--no-noise", action="store_true", help="sensor readings without their Gaussian noise")


def sensor_options(args: argparse.Namespace) -> dict[str, Any]:
    """Simulator keyword arguments from the sensor switches."""
    return {
        "lidar": not args.no_lidar,
        "camera": not args.no_camera,
        "sensor_noise": not args.no_noise,
        "sensors_off": tuple(getattr(args, "no_sensor", ())),
    }


def check_folder(flag: str, folder: Path) -> None:
    """`folder` exists as a writable folder, or can be made inside one."""
    existing = folder
    while not existing.exists() and existing != existing.parent:
        existing = existing.parent
    if not existing.is_dir():
        raise ConfigError(f"{flag} {folder}: {existing} is not a folder")
    if not os.access(existing, os.W_OK | os.X_OK):
        raise ConfigError(f"{flag} {folder}: {existing} is not writable")


def make_folder(flag: str, folder: Path) -> None:
    """Create `folder` (and its parents); ConfigError naming the flag if that fails."""
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise ConfigError(f"{flag} {folder}: cannot create the folder ({exc.strerror or exc})") from None


def fresh_folder(flag: str, base: Path) -> Path:
    """`base`, or base-2, base-3, ...: the first of them that did not exist, made now (mkdir is atomic: two runs
    started in the same second get a runs/<date-time> folder each)."""
    for k in itertools.count(1):
        folder = base if k == 1 else base.with_name(f"{base.name}-{k}")
        try:
            folder.mkdir(parents=True)
            return folder
        except FileExistsError:
            continue
        except OSError as exc:
            raise ConfigError(f"{flag} {folder}: cannot create the folder ({exc.strerror or exc})") from None
    raise AssertionError("unreachable")


def add_overwrite_argument(p: argparse.ArgumentParser) -> None:
    """--overwrite: a recording file that exists is replaced (without it, refused)."""
    p.add_argument(
        "--overwrite",
        action="store_true",
        help="replace a recording file that exists (default: refuse it; a recording is never replaced "
        "unless asked, and never written by two runs at once)",
    )


def check_record_path(record: Path, flag: str = "--record", overwrite: bool = True) -> None:
    """An MCAP path that can be written: not a folder, in a folder that exists or can be made, and (without
    `overwrite`) not a file that exists. The file is taken exclusively when the recording starts
    (recording.open_recording_file): this is the early look, before the sim is built."""
    if record.is_dir():
        raise ConfigError(f"{flag} {record}: is a folder; give a file name such as {record / 'run.mcap'}")
    check_folder(flag, record.parent)
    if not overwrite and (record.exists() or record.is_symlink()):
        raise ConfigError(
            f"{flag} {record}: the file exists and a recording is never replaced unless asked: give "
            "--overwrite to replace it, or another file name"
        )


def start_line(text: str) -> tuple[float, float, float, float]:
    """'x1,y1,x2,y2': the two ends of a start line (m), where laps are counted."""
    parts = text.split(",")
    if len(parts) != 4:
        raise argparse.ArgumentTypeError(f"'{text}' is not x1,y1,x2,y2 (the start line's two ends, m)")
    x1, y1, x2, y2 = (finite_float(p) for p in parts)
    for value in (x1, y1, x2, y2):
        if abs(value) > MAX_COORDINATE:
            raise argparse.ArgumentTypeError(
                f"'{text}': {value:g} m is beyond the largest world coordinate (±{MAX_COORDINATE:g} m)"
            )
    if (x1, y1) == (x2, y2):
        raise argparse.ArgumentTypeError(f"'{text}': the start line's two ends are the same point")
    return x1, y1, x2, y2


_CAR_PREFIX = re.compile(r"(car[1-9][0-9]*)=(.*)", re.S)


@dataclass(frozen=True)
class PerCar:
    """A value for every car (`car` None) or for one car of a fleet (`car1=...`)."""

    car: str | None
    value: str


def driver_choice(text: str) -> PerCar:
    """`--driver`: a built-in driver, `module:Class` or `file.py:Class`, for every car or for one (`car2=...`)."""
    from racecar_sim.runtime.driving import DRIVERS, is_node_spec  # the drivers load only for a run

    match = _CAR_PREFIX.fullmatch(text)
    car, spec = (match.group(1), match.group(2)) if match else (None, text)
    if spec not in DRIVERS and not is_node_spec(spec):
        raise argparse.ArgumentTypeError(
            f"'{text}' is not a driver: give {', '.join(DRIVERS)}, package.module:Class or path/to/file.py:Class "
            "(carK=DRIVER for one car of --cars)"
        )
    return PerCar(car, spec)


def per_car_file(text: str) -> PerCar:
    """`--driver-config`: a YAML file for every car, or for one (`car2=FILE`)."""
    match = _CAR_PREFIX.fullmatch(text)
    car, path = (match.group(1), match.group(2)) if match else (None, text)
    if not path:
        raise argparse.ArgumentTypeError(f"'{text}' names no file")
    return PerCar(car, path)


def per_car(values: list[PerCar] | None, flag: str, cars: list[str], fleet: bool) -> list[str | None]:
    """The value of a per-car option for each car (None where none is given): a plain value for every car, `carK=`
    for car K over it. ConfigError (one line) for two plain values, a car twice, `carK=` without a fleet or for a
    car the fleet does not have."""
    plain = [v for v in values or [] if v.car is None]
    if len(plain) > 1:
        raise ConfigError(
            f"{flag} {plain[0].value} and {flag} {plain[1].value}: one {flag} is for every car; give carK=VALUE for "
            "one car of --cars"
        )
    chosen: list[str | None] = [plain[0].value if plain else None] * len(cars)
    named: set[str] = set()
    for value in values or []:
        if value.car is None:
            continue
        if not fleet:
            raise ConfigError(f"{flag} {value.car}={value.value}: cars are named only in a fleet: give --cars N too")
        if value.car in named:
            raise ConfigError(f"{flag} {value.car}=...: given twice for {value.car}")
        if value.car not in cars:
            raise ConfigError(f"{flag} {value.car}={value.value}: the run has {len(cars)} cars ({cars[0]}..{cars[-1]})")
        named.add(value.car)
        chosen[cars.index(value.car)] = value.value
    return chosen


def add_driver_arguments(p: argparse.ArgumentParser, default: str = "") -> None:
    """--driver (repeatable: carK=DRIVER for one car of a fleet) and --driver-config (`default`: what drives without
    --driver, for the help)."""
    from racecar_sim.runtime.driving import DRIVERS  # the drivers load only for a command that takes them

    p.add_argument(
        "--driver",
        type=driver_choice,
        action="append",
        metavar="DRIVER",
        help=f"{', '.join(DRIVERS)}; or your own node class, package.module:Class or path/to/file.py:Class, built as "
        "Class(ctx, **settings) (docs/drivers.md); carK=DRIVER gives car K of a fleet its own (repeatable)"
        + (f". {default}" if default else ""),
    )
    p.add_argument(
        "--driver-config",
        type=per_car_file,
        action="append",
        metavar="FILE.yaml",
        help="the driver's settings from a YAML file: any fields of drivers/data/wall_follow.yaml or "
        "pure_pursuit.yaml (the others keep the package's defaults), the constant command's speed/steering/rate, "
        "or your class's keyword arguments; options on the command line win over it; carK=FILE for one car",
    )


def add_output_arguments(p: argparse.ArgumentParser, default_out: str) -> None:
    """--out, --record, --no-record, --raw-images, --no-video, --no-summary and --overwrite: the run folder
    (cli/run_folder.py). `default_out`: what --out is without it, for the help."""
    p.add_argument(
        "--out",
        metavar="DIR",
        help=f"folder for the run's files: run.mcap, summary.png, summary.json, camera.mp4 (default {default_out})",
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
    p.add_argument("--no-summary", action="store_true", help="no summary.png and summary.json")


def add_start_line_argument(p: argparse.ArgumentParser) -> None:
    """--start-line x1,y1,x2,y2."""
    p.add_argument(
        "--start-line",
        type=start_line,
        metavar="X1,Y1,X2,Y2",
        help="where laps are counted and timed: a segment crossed forward along the spawn heading (default: the "
        "world's own, e.g. walker's checkered line or a track CSV's first point)",
    )


def add_run_options(
    p: argparse.ArgumentParser, default_out: str, ros_help: str | None = None, paced_by_default: str = ""
) -> None:
    """The options run, teleop, launch (and play) share, for the same things: the run folder (add_output_arguments),
    --start-line, the sensor switches, --viewer and --foxglove, --realtime and --fast, and the bridges (--ros,
    --ros-master, --ros2, --topic-map). SHARED_OPTIONS lists them."""
    from racecar_sim.cli.live import add_live_arguments, add_pacing_arguments
    from racecar_sim.cli.ros2_env import add_ros2_arguments
    from racecar_sim.cli.ros_env import add_ros_arguments
    from racecar_sim.cli.topic_map import add_topic_map_argument

    add_output_arguments(p, default_out)
    add_start_line_argument(p)
    add_sensor_arguments(p)
    add_live_arguments(p)
    add_pacing_arguments(p, paced_by_default)
    add_ros_arguments(p, ros_help)
    add_ros2_arguments(p)
    add_topic_map_argument(p)


# every option add_run_options gives, with a value that parses (the test of the shared options walks this)
SHARED_OPTIONS: dict[str, tuple[str, ...]] = {
    "--out": ("DIR",),
    "--record": ("run.mcap",),
    "--no-record": (),
    "--raw-images": (),
    "--no-video": (),
    "--no-summary": (),
    "--overwrite": (),
    "--start-line": ("1,-1,1,1",),
    "--no-lidar": (),
    "--no-camera": (),
    "--no-sensor": ("imu",),
    "--no-noise": (),
    "--viewer": (),
    "--foxglove": ("8765",),
    "--realtime": (),
    "--fast": (),
    "--ros": (),
    "--ros-master": ("http://127.0.0.1:11311/",),
    "--ros2": (),
    "--topic-map": ("f1tenth",),
}
