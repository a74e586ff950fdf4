"""Spawn poses checked against the world before any car is built, each refusal one line naming the option.

The Simulator checks every car once the whole fleet is built, and building N cars costs ~N² (MuJoCo's model
editing: 100 cars 3 s, 400 cars 30 s); here the world and one car are compiled once (physics.SpawnProbe) and the
row is checked pose by pose, so `--cars 1000` on a course that takes 6 is refused in a second, with the number of
cars that fit.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

import numpy as np

from racecar_sim.cli.args import XacroOptions
from racecar_sim.core.errors import WorldError
from racecar_sim.physics import load_preset
from racecar_sim.physics.spawn_check import CarOverlap, SpawnProbe
from racecar_sim.runtime import Car
from racecar_sim.worlds import Spawn, World

# Building the model grows with the square of the cars in MuJoCo's spec editing and compiler (200 cars: 5 s, 400:
# 31 s). The lidars' memory grows with the cars only (one posed copy of the world and one slicing of its walls for
# the whole fleet, sensors/shared_pose.py): 256 cars in a grid in `empty`, lidar on, camera off, to the first step,
# 2-core CPU: 13 s and 0.5 GB (3.0 GB when each lidar kept its own copy). More than this is refused before anything
# is built.
MAX_CARS = 256


def fleet_size(text: str) -> int:
    """--cars: a whole number from 1 to MAX_CARS."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"'{text}' is not a whole number") from None
    if not 1 <= value <= MAX_CARS:
        raise argparse.ArgumentTypeError(
            f"'{text}' must be from 1 to {MAX_CARS}, the most cars one run takes (the "
            f"model's build time grows with the square of the cars: {MAX_CARS} take "
            f"about 15 s and 0.5 GB)"
        )
    return value


def spawn_text(spawn: Spawn, sep: str = ",") -> str:
    """A pose as --spawn takes it (x,y,z,yaw)."""
    return sep.join(f"{v:g}" for v in (spawn.x, spawn.y, spawn.z, spawn.yaw))


def probe(world: World, args: argparse.Namespace) -> SpawnProbe | None:
    """The world with the run's car (--xacro, --xacro-arg, --profile) compiled for spawn checks; None where MuJoCo
    refuses the world itself (the Simulator's build says so in its own words)."""
    options: XacroOptions = {}
    if getattr(args, "xacro", None) is not None:
        options["xacro"] = Path(args.xacro)
    if getattr(args, "xacro_args", None):
        options["xacro_args"] = dict(args.xacro_args)
    car = Car(profile=getattr(args, "profile", "seed"), lidar=False, camera=False, **options)
    car.load()
    try:
        return SpawnProbe(world, car.robot, load_preset(getattr(args, "physics", "default")))
    except ValueError:
        return None


def check_spawn_option(world: World, args: argparse.Namespace) -> None:
    """--spawn checked against the world (inside an obstacle, below the ground, over nothing): WorldError naming
    the option."""
    if args.spawn is None:
        return
    checker = probe(world, args)
    if checker is None:
        return
    try:
        checker.check(args.spawn)
    except WorldError as exc:
        raise WorldError(f"--spawn: {exc}") from None


def check_row(
    world: World, args: argparse.Namespace, spawns: list[Spawn], spacing: float, centerline: np.ndarray | None
) -> None:
    """A fleet's row of spawn poses (car1 first) checked against the world before any car is built: WorldError
    naming the option, the first car that does not fit and how many do. A straight row (no `centerline`) is also
    refused where a wall stands between two cars (past a bend of a course); a row round a closed centerline where
    it would come round onto car1."""
    count = len(spawns)
    row = f"--cars {count} --car-spacing {spacing:g}"
    if centerline is not None and count > 1:
        points = np.asarray(centerline, dtype=float)
        lap = float(np.hypot(*(np.roll(points, -1, axis=0) - points).T).sum())
        fits = max(1, math.floor(lap / spacing + 1e-9))
        if count > fits:
            raise WorldError(
                f"{row}: {world.label}: the track's centerline is {lap:.1f} m round: it takes "
                f"{_cars(fits)} {spacing:g} m apart (use fewer --cars or a smaller --car-spacing)"
            )
    checker = probe(world, args)
    if checker is None:
        return
    for k, spawn in enumerate(spawns):
        name, before = f"car{k + 1}", f"car{k}"
        try:
            checker.check(spawn, name, [(f"car{j + 1}", spawns[j]) for j in range(k)])
            wall = checker.wall_between(spawns[k - 1], spawn) if k and centerline is None else None
            if wall is not None:
                raise WorldError(
                    f"{world.label}: {name}'s spawn pose ({spawn_text(spawn, ', ')}) is on the far side "
                    f"of {wall} from {before} (the cars line up straight back along the spawn heading)"
                )
        except CarOverlap as exc:  # cars closer than a car's length
            raise WorldError(f"--car-spacing {spacing:g}: {exc} (use a larger --car-spacing)") from None
        except WorldError as exc:
            if k == 0:  # car1: the spawn pose itself
                raise WorldError(f"--spawn: {exc}" if args.spawn is not None else str(exc)) from None
            raise WorldError(
                f"{row}: {exc}; this world takes {_cars(k)} in a row at {spacing:g} m from its spawn "
                "pose (use fewer --cars or a smaller --car-spacing)"
            ) from None


def _cars(count: int) -> str:
    return f"{count} car{'s' if count != 1 else ''}"
