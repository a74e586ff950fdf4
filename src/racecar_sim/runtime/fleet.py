"""A fleet's checks: the cars a Simulator is given, and the spawn poses reset() is given for them."""

from __future__ import annotations

from collections.abc import Mapping, Sequence

from racecar_sim.core.errors import ConfigError
from racecar_sim.core.throttle import is_finite_number
from racecar_sim.runtime.car import Car
from racecar_sim.worlds import Spawn


def checked_fleet(cars: Sequence[Car]) -> list[Car]:
    """The cars as a list; ConfigError for none, two of one name, or a car after the first without a spawn pose."""
    cars = list(cars)
    if not cars:
        raise ConfigError("a Simulator needs at least one car")
    names = [car.model_name for car in cars]
    if len(set(names)) != len(names):
        raise ConfigError(f"car names must differ, got {', '.join(names)}")
    if any(car.spawn is None for car in cars[1:]):
        missing = [car.model_name for car in cars[1:] if car.spawn is None]
        raise ConfigError(f"only the first car takes the world's spawn pose: give {', '.join(missing)} a spawn")
    return cars


def car_index(cars: Sequence[Car], name: str) -> int:
    """The index of the car of this namespace or Gazebo model name; KeyError naming the cars if none."""
    for index, car in enumerate(cars):
        if name in (car.name, car.model_name):
            return index
    raise KeyError(f"no car named {name!r} (cars: {', '.join(c.model_name for c in cars)})")


def spawn_poses(cars: Sequence[Car], spawn: Spawn | Mapping[str, Spawn] | Sequence[Spawn] | None) -> dict[int, Spawn]:
    """reset()'s spawn argument as {car index: pose}; ConfigError for an unknown car or a pose that is not a Spawn
    of finite numbers."""
    if spawn is None:
        return {}
    poses: dict[int, Spawn]
    if isinstance(spawn, Spawn):
        poses = {0: spawn}
    elif isinstance(spawn, Mapping):
        poses = {}
        for name, pose in spawn.items():
            try:
                poses[car_index(cars, name)] = pose
            except KeyError as exc:
                raise ConfigError(f"reset spawn: {exc.args[0]}") from None
    elif isinstance(spawn, Sequence) and not isinstance(spawn, str):
        if len(spawn) > len(cars):
            raise ConfigError(f"reset spawn: {len(spawn)} spawn poses for {len(cars)} cars")
        poses = dict(enumerate(spawn))
    else:
        raise ConfigError(f"reset spawn={spawn!r}: give a Spawn, a Spawn per car, or a mapping of car names to Spawns")
    for index, pose in poses.items():
        who = f"reset spawn for {cars[index].model_name}"
        if not isinstance(pose, Spawn):
            raise ConfigError(f"{who}: {pose!r} is not a Spawn(x, y, z, yaw)")
        for name in ("x", "y", "z", "yaw"):
            if not is_finite_number(getattr(pose, name)):
                raise ConfigError(f"{who}: {name} must be a finite number, got {getattr(pose, name)!r} ({pose})")
    return poses
