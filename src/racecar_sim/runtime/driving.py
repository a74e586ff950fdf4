"""A driver node by name: `attach_driver(sim, car, "wall-follow", {"distance": 0.7})` starts one on the car's topics.

Shared by `racecar-sim run` (its --speed/--distance/... options) and `racecar-sim sweep` (a grid of parameters).

A driver is one of the built-in DRIVERS, or a user's node written to the node contract (racecar_sim.nodes), named
`package.module:Class` or `path/to/file.py:Class`: built as `sim.add_node(Class, car=car, **params)`, i.e.
`Class(ctx, **params)` from the car's NodeContext. `driver_settings(FILE, driver)` reads a YAML file of a driver's
parameters (wall_follow.yaml's or pure_pursuit.yaml's fields, or a user class's keyword arguments).
"""

from __future__ import annotations

import dataclasses
import importlib
import importlib.util
import inspect
import os
import sys
import typing
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

from racecar_sim.core.errors import ConfigError
from racecar_sim.core.names import NAVIGATION, ODOM
from racecar_sim.core.tables import checked_value, finite_number, read_table
from racecar_sim.description.vehicle import VehicleGeometry
from racecar_sim.drivers import (
    ConstantCommand,
    PurePursuit,
    PurePursuitConfig,
    WallFollowConfig,
    WallFollower,
    Waypoints,
    load_waypoints,
    pure_pursuit_config,
    wall_follow_config,
)
from racecar_sim.nodes import Node
from racecar_sim.nodes.guard import FILE_MODULE_PREFIX
from racecar_sim.runtime.car import Car
from racecar_sim.runtime.simulator import Simulator
from racecar_sim.worlds import World, track_file  # noqa: F401 (track_file: sweep/spec.py asks it of a world's name)

DRIVERS = ("wall-follow", "pure-pursuit", "constant")
CONSTANT_DEFAULTS = {"speed": 1.0, "steering": 0.0, "rate": 20.0}


NODE_HOOKS = ("reset", "rebind", "close")  # what makes a class a node (racecar_sim.nodes.Node)


def is_node_spec(driver: str) -> bool:
    """Whether `driver` names a user's node class (`module:Class`, `file.py:Class`) rather than a built-in driver."""
    return ":" in driver and driver not in DRIVERS


def load_node_class(spec: str) -> Callable[..., Node]:
    """The node class `spec` names: `package.module:Class` (imported as Python imports it, the current folder on the
    path too) or `path/to/file.py:Class` (loaded from that file). ConfigError, one line, for a module or file that
    cannot be loaded, a class it lacks, or one that is not a node (no reset / rebind / close hooks)."""
    target, sep, name = spec.rpartition(":")
    where = f"driver {spec}"
    if not sep or not target or not name.isidentifier():
        raise ConfigError(f"{where}: give a built-in driver ({', '.join(DRIVERS)}), module:Class or file.py:Class")
    is_file = target.endswith(".py") or "/" in target or os.sep in target
    module = _load_file(target, where) if is_file else _import_module(target, where)
    factory = getattr(module, name, None)
    if factory is None:
        classes = sorted(n for n, v in vars(module).items() if inspect.isclass(v) and v.__module__ == module.__name__)
        defines = f" (it defines: {', '.join(classes)})" if classes else ""
        raise ConfigError(f"{where}: {target} has no {name}{defines}")
    if not inspect.isclass(factory):
        raise ConfigError(f"{where}: {name} is a {type(factory).__name__}, not a class")
    missing = [hook for hook in NODE_HOOKS if not callable(getattr(factory, hook, None))]
    if missing:
        raise ConfigError(
            f"{where}: {name} is not a node: it has no {', '.join(missing)} (subclass racecar_sim.nodes.NodeBase)"
        )
    return typing.cast(Callable[..., Node], factory)


def _reason(exc: BaseException) -> str:
    return " ".join(f"{type(exc).__name__}: {exc}".split())


def _load_file(target: str, where: str) -> Any:
    path = Path(target).expanduser()
    if not path.is_file():
        raise ConfigError(f"{where}: no such file {target}")
    resolved = path.resolve()
    import hashlib  # OpenSSL's ~10 ms, only for a user's driver file

    name = f"{FILE_MODULE_PREFIX}{hashlib.sha1(str(resolved).encode()).hexdigest()[:12]}_{path.stem}"
    if name in sys.modules:
        return sys.modules[name]
    spec = importlib.util.spec_from_file_location(name, resolved)
    if spec is None or spec.loader is None:
        raise ConfigError(f"{where}: {target} is not a Python file")
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module  # dataclasses and pickling look the module up by name
    try:
        spec.loader.exec_module(module)
    except Exception as exc:  # the user's file: a syntax error, an import it lacks, an error at its top level
        del sys.modules[name]
        raise ConfigError(f"{where}: {target} cannot be loaded ({_reason(exc)})") from None
    return module


def _import_module(target: str, where: str) -> Any:
    if not all(part.isidentifier() for part in target.split(".")):
        raise ConfigError(f"{where}: {target!r} is neither a module name nor a .py file")
    if os.getcwd() not in sys.path and "" not in sys.path:
        sys.path.append(os.getcwd())  # as `python -m` has it: a package in the current folder imports
    try:
        return importlib.import_module(target)
    except Exception as exc:
        raise ConfigError(f"{where}: cannot import {target} ({_reason(exc)})") from None


def _node_parameters(factory: Callable[..., Node]) -> tuple[str, ...] | None:
    """The keyword arguments a node class takes after the context (None: any, it has **kwargs)."""
    try:
        parameters = list(inspect.signature(factory).parameters.values())[1:]
    except (TypeError, ValueError):
        return None
    if any(p.kind is inspect.Parameter.VAR_KEYWORD for p in parameters):
        return None
    kinds = (inspect.Parameter.POSITIONAL_OR_KEYWORD, inspect.Parameter.KEYWORD_ONLY)
    return tuple(p.name for p in parameters if p.kind in kinds)


def _check_node_call(factory: Callable[..., Node], spec: str, params: Mapping[str, object], where: str) -> None:
    """ConfigError unless `factory(ctx, **params)` fits the class's signature."""
    try:
        signature = inspect.signature(factory)
    except (TypeError, ValueError):
        return
    try:
        signature.bind(None, **params)
    except TypeError as exc:
        name = getattr(factory, "__name__", spec)
        given = "".join(f", {key}=..." for key in params)
        raise ConfigError(f"{where}: {name}(ctx{given}) does not fit {name}{signature}: {exc}") from None


def driver_parameters(driver: str) -> tuple[str, ...]:
    """The parameter names `driver` takes: its YAML's fields (drivers/data), `path` for pure-pursuit, the
    constant command's speed, steering and rate, or a user node class's keyword arguments."""
    if is_node_spec(driver):
        return _node_parameters(load_node_class(driver)) or ()
    if driver == "wall-follow":
        return tuple(f.name for f in dataclasses.fields(WallFollowConfig))
    if driver == "pure-pursuit":
        return ("path", *(f.name for f in dataclasses.fields(PurePursuitConfig)))
    if driver == "constant":
        return tuple(CONSTANT_DEFAULTS)
    raise ConfigError(f"unknown driver {driver!r} (choose from: {', '.join(DRIVERS)})")


def track_path(world: World) -> Waypoints | None:
    """What pure-pursuit follows in `world` unless given a path: a race track's centerline (a loop), None for a world
    that is not a track."""
    line = world.centerline
    if line is None or not world.is_track:
        return None
    return Waypoints(line.points, None, True, line.source)


def attach_driver(
    sim: Simulator,
    car: Car,
    driver: str,
    params: Mapping[str, object] | None = None,
    topic: str | None = None,
    scan_topic: str | None = None,
    odom_topic: str | None = None,
) -> object:
    """A new `driver` node for `car`, on its topics (`/carK/...` in a fleet), commanding the navigation mux input.

    `topic`, `scan_topic`, `odom_topic`: other topics than the car's navigation input, scan and odometry (a
    launch file's remaps).

    `params` override the driver's defaults (None values keep them); pure-pursuit's `path` defaults to the world's
    track CSV and its wheelbase to the car's own. ConfigError (one line) for an unknown driver or parameter, a
    wall-follow car without a lidar, a pure-pursuit without a path, or a bad value.
    """
    params = {name: value for name, value in (params or {}).items() if value is not None}
    if is_node_spec(driver):  # a user's node: Class(ctx, **params) from the car's context
        factory = load_node_class(driver)
        _check_node_call(factory, driver, params, f"driver {driver}")
        return sim.add_node(factory, car=car, **params)
    known = driver_parameters(driver)
    unknown = sorted(set(params) - set(known))
    if unknown:
        raise ConfigError(f"{driver} has no parameter {unknown[0]!r} (it takes: {', '.join(known)})")
    navigation, odom = topic or car.topic(NAVIGATION), odom_topic or car.topic(ODOM)
    if driver == "constant":
        options = {
            name: finite_number(value, f"constant: {name}") for name, value in {**CONSTANT_DEFAULTS, **params}.items()
        }
        # ConfigError from the scheduler for a rate above the physics rate
        return car.hold(
            ConstantCommand(
                sim.bus, sim.scheduler, options["speed"], options["steering"], options["rate"], topic=navigation
            )
        )
    if driver == "wall-follow":
        if not scan_topic:  # a given scan topic may be fed from elsewhere (ROS)
            lidar = car.lidar
            if lidar is None:
                raise ConfigError("wall-follow steers by the lidar: the car needs its lidar on")
            scan_topic = lidar.topic
        return car.hold(
            WallFollower(
                sim.bus,
                wall_follow_config(**params),
                topic=navigation,
                scan_topic=scan_topic,
                odom_topic=odom,
            )
        )
    path = params.pop("path", None)
    if path is not None and not isinstance(path, (str, Path)):
        raise ConfigError(f"pure-pursuit: path must be a file name, got {path!r}")
    waypoints = load_waypoints(path) if path else track_path(sim.world)
    if waypoints is None:
        raise ConfigError(
            "pure-pursuit needs a path: a waypoint CSV (x,y[,speed]) or a track centerline, or a track "
            ".csv as the world"
        )
    wheelbase = VehicleGeometry.from_robot(car.robot).wheelbase  # the loaded xacro's, not the YAML's default
    config = pure_pursuit_config(**{"wheelbase": wheelbase, **params})
    return car.hold(PurePursuit(sim.bus, waypoints, config, topic=navigation, odom_topic=odom))


def driver_settings(path: str | Path, driver: str) -> dict[str, Any]:
    """The parameters of `driver` in the YAML file `path` (any of its fields: wall_follow.yaml's, pure_pursuit.yaml's
    (and `path`), the constant command's, or a user node class's keyword arguments), values checked as the package's
    own files are. ConfigError naming the file and the field for an unknown field or a bad value."""
    path = Path(path)
    if not path.is_file():
        raise ConfigError(f"{path}: no such file (a YAML mapping of the driver's settings)")
    data = read_table(path)
    if is_node_spec(driver):
        factory = load_node_class(driver)
        known = _node_parameters(factory)
        if known is not None:
            unknown = sorted(set(data) - set(known))
            if unknown:
                takes = ", ".join(known) if known else "no parameters"
                raise ConfigError(f"{path}: unknown field {unknown[0]!r} for {driver} (it takes: {takes})")
        return dict(data)
    known = driver_parameters(driver)
    unknown = sorted(set(data) - set(known))
    if unknown:
        raise ConfigError(f"{path}: unknown field {unknown[0]!r} for {driver} (it takes: {', '.join(known)})")
    config_class = {"wall-follow": WallFollowConfig, "pure-pursuit": PurePursuitConfig}.get(driver)
    hints = typing.get_type_hints(config_class) if config_class is not None else {}
    values: dict[str, Any] = {}
    for name, value in data.items():
        if name in hints:
            values[name] = checked_value(hints[name], value, f"{path}: {name}")
        elif name == "path":
            if not isinstance(value, str):
                raise ConfigError(f"{path}: path: expected a file name, got {value!r}")
            values[name] = str((path.parent / value) if not Path(value).is_absolute() else value)
        else:
            values[name] = finite_number(value, f"{path}: {name}")
    return values
