"""A driver node by name: `attach_driver(sim, car, "wall-follow", {"distance": 0.7})` starts one on the car's topics.

Shared by `racecar-sim run` (its --speed/--distance/... options) and `racecar-sim sweep` (a grid of parameters).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from pathlib import Path

from racecar_sim.core.errors import ConfigError
from racecar_sim.core.names import NAVIGATION, ODOM
from racecar_sim.core.tables import finite_number
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
from racecar_sim.runtime.car import Car
from racecar_sim.runtime.simulator import Simulator
from racecar_sim.worlds import World, track_file  # noqa: F401 (track_file: sweep/spec.py asks it of a world's name)

DRIVERS = ("wall-follow", "pure-pursuit", "constant")
CONSTANT_DEFAULTS = {"speed": 1.0, "steering": 0.0, "rate": 20.0}


def driver_parameters(driver: str) -> tuple[str, ...]:
    """The parameter names `driver` takes: its YAML's fields (drivers/data), `path` for pure-pursuit, or the
    constant command's speed, steering and rate."""
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
