"""A sweep file: worlds x drivers (each with a grid of its parameters) x seeds, each cell one episode.

    duration: 30            # sim seconds per episode
    worlds: [walker, tunnel]   # built-in names or world files (relative to this file's folder)
    seeds: [0, 1, 2]        # or a count: `seeds: 3` is 0, 1, 2
    drivers:
      - driver: wall-follow
        params:             # a list is the values to sweep, a single value is fixed
          distance: [0.7, 0.9]
          speed: 2.0
      - constant            # a driver with its defaults
    camera: false           # the ZED camera (off by default in a sweep: it costs the most)
    lidar: true
    noise: true             # Gaussian sensor noise
    physics: default        # a physics preset
    profile: seed           # a driving profile
    record: true            # each episode's run.mcap
    summary_png: false      # each episode's summary.png (the summary.json is always written)

Parameter names are the driver's: wall_follow.yaml's or pure_pursuit.yaml's fields (drivers/data), pure-pursuit's
`path`, or the constant command's speed, steering and rate. A parameter that is itself a list (wall-follow's
`sector`) is swept when given a list of such lists.
"""

from __future__ import annotations

import itertools
import math
import re
import typing
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

from racecar_sim.control.profiles import profile_names
from racecar_sim.core.errors import ConfigError
from racecar_sim.core.tables import finite_number
from racecar_sim.drivers import PurePursuitConfig, WallFollowConfig, pure_pursuit_config, wall_follow_config
from racecar_sim.drivers.config import DATA as DRIVER_DATA
from racecar_sim.physics import preset_names
from racecar_sim.runtime.driving import CONSTANT_DEFAULTS, driver_parameters
from racecar_sim.worlds import track_file
from racecar_sim.worlds.catalog import world_names

FIELDS = {
    "duration",
    "worlds",
    "seeds",
    "drivers",
    "camera",
    "lidar",
    "noise",
    "physics",
    "profile",
    "record",
    "summary_png",
}
DEFAULT_DURATION = 30.0  # s of sim time per episode
# The most episodes one sweep runs: each leaves a folder of files (a run.mcap of ~8 MB a minute without the camera)
# and a row the table holds until the end, and is a Ray task; the grid's size is counted before anything is built.
MAX_EPISODES = 100_000
_CONFIGS = {"wall-follow": WallFollowConfig, "pure-pursuit": PurePursuitConfig}
_UNSAFE = re.compile(r"[^A-Za-z0-9_.-]+")


@dataclass(frozen=True)
class DriverGrid:
    """One driver and its parameters: each name maps to the values swept (one value: fixed)."""

    driver: str
    params: dict[str, list[Any]] = field(default_factory=dict)

    def combinations(self) -> Iterator[dict[str, Any]]:
        """The cartesian product of the parameter values, in the file's order (one empty dict with none), made one
        at a time."""
        names = list(self.params)
        return (dict(zip(names, values)) for values in itertools.product(*(self.params[n] for n in names)))

    @property
    def size(self) -> int:
        """How many combinations there are (counted, not made)."""
        return math.prod(len(values) for values in self.params.values())


@dataclass(frozen=True)
class RunSettings:
    """What every episode of a sweep shares: its sim time, sensors, physics, profile and what it writes."""

    duration: float
    camera: bool = False
    lidar: bool = True
    noise: bool = True
    physics: str = "default"
    profile: str = "seed"
    record: bool = True
    summary_png: bool = False


@dataclass(frozen=True)
class Episode:
    """One cell of the grid: a world, a driver with its parameter values, a seed, and the shared settings."""

    index: int
    world: str
    driver: str
    params: dict[str, Any]
    seed: int
    settings: RunSettings

    @property
    def world_label(self) -> str:
        """The world's name for folders and tables: a built-in name, or a world file's stem."""
        return self.world if self.world in world_names() else Path(self.world).stem

    @property
    def folder_name(self) -> str:
        """runs/<index>-<world>-<driver>-seed<k>: sorts in the grid's order."""
        return _UNSAFE.sub("_", f"{self.index:03d}-{self.world_label}-{self.driver}-seed{self.seed}")


@dataclass(frozen=True)
class SweepSpec:
    """A sweep file read and checked: `episodes()` is the grid, worlds outermost, seeds innermost."""

    source: str
    worlds: list[str]
    seeds: Sequence[int]  # a list, or the range of `seeds: N`
    drivers: list[DriverGrid]
    settings: RunSettings

    @property
    def size(self) -> int:
        """How many episodes the grid holds (counted, not made)."""
        return len(self.worlds) * sum(grid.size for grid in self.drivers) * len(self.seeds)

    def iter_episodes(self) -> Iterator[Episode]:
        """Every world x driver x parameter combination x seed, numbered from 0, made one at a time."""
        cells = (
            (world, grid.driver, params, seed)
            for world in self.worlds
            for grid in self.drivers
            for params in grid.combinations()
            for seed in self.seeds
        )
        return (
            Episode(i, world, driver, params, seed, self.settings)
            for i, (world, driver, params, seed) in enumerate(cells)
        )

    def episodes(self) -> list[Episode]:
        """Every episode, as a list (iter_episodes makes them one at a time)."""
        return list(self.iter_episodes())

    @property
    def param_names(self) -> list[str]:
        """Every parameter name given to any driver, in first-seen order (the table's param_ columns)."""
        names: dict[str, None] = {}
        for grid in self.drivers:
            names.update(dict.fromkeys(grid.params))
        return list(names)


def load_sweep(path: str | Path) -> SweepSpec:
    """Read and check a sweep file; ConfigError (one line) naming the file and the field at fault."""
    path = Path(path)
    try:
        data = yaml.safe_load(path.read_text())
    except OSError as exc:
        raise ConfigError(f"{path}: cannot read the sweep file ({exc.strerror or exc})") from None
    except yaml.YAMLError as exc:
        raise ConfigError(f"{path}: not valid YAML: {' '.join(str(exc).split())}") from None
    if not isinstance(data, dict):
        raise ConfigError(f"{path}: a sweep file is a mapping with worlds, seeds and drivers (see examples/)")
    unknown = sorted(set(data) - FIELDS)
    if unknown:
        raise ConfigError(f"{path}: unknown field {unknown[0]!r} (fields: {', '.join(sorted(FIELDS))})")
    missing = [name for name in ("worlds", "seeds", "drivers") if name not in data]
    if missing:
        raise ConfigError(f"{path}: missing field {missing[0]!r}")

    def where(name: str) -> str:
        return f"{path}: {name}"

    duration = finite_number(data.get("duration", DEFAULT_DURATION), where("duration"))
    if duration <= 0:
        raise ConfigError(f"{where('duration')}: must be positive seconds of sim time, got {duration:g}")
    flags = {
        name: _flag(data, name, default, where(name))
        for name, default in (
            ("camera", False),
            ("lidar", True),
            ("noise", True),
            ("record", True),
            ("summary_png", False),
        )
    }
    physics = _choice(data.get("physics", "default"), preset_names(), where("physics"))
    profile = _choice(data.get("profile", "seed"), profile_names(), where("profile"))
    worlds = _worlds(data["worlds"], path)
    seeds = _seeds(data["seeds"], where("seeds"))
    drivers = _drivers(data["drivers"], path, len(worlds) * len(seeds))
    if not flags["lidar"] and any(grid.driver == "wall-follow" for grid in drivers):
        raise ConfigError(f"{where('lidar')}: wall-follow steers by the lidar: set lidar: true or drop wall-follow")
    pathless = [w for w in worlds if track_file(w) is None]
    for k, grid in enumerate(drivers):
        if grid.driver == "pure-pursuit" and "path" not in grid.params and pathless:
            raise ConfigError(
                f"{path}: drivers[{k}].params.path: pure-pursuit needs a path (a waypoint CSV) on "
                f"{pathless[0]!r}, which is not a track .csv"
            )
    return SweepSpec(
        str(path), worlds, seeds, drivers, RunSettings(duration, physics=physics, profile=profile, **flags)
    )


def _flag(data: dict[str, object], name: str, default: bool, where: str) -> bool:
    value = data.get(name, default)
    if not isinstance(value, bool):
        raise ConfigError(f"{where}: expected true or false, got {value!r}")
    return value


def _choice(value: object, choices: list[str], where: str) -> str:
    if value not in choices:
        raise ConfigError(f"{where}: unknown {value!r} (choose from: {', '.join(choices)})")
    return str(value)


def _as_list(value: object, where: str) -> list[object]:
    values = value if isinstance(value, list) else [value]
    if not values:
        raise ConfigError(f"{where}: an empty list sweeps nothing: give at least one value")
    return values


def _worlds(value: object, path: Path) -> list[str]:
    worlds = []
    for world in _as_list(value, f"{path}: worlds"):
        if not isinstance(world, str) or not world:
            raise ConfigError(f"{path}: worlds: expected a built-in world name or a world file, got {world!r}")
        if world not in world_names():
            file = path.parent / world
            if not file.is_file():
                raise ConfigError(
                    f"{path}: worlds: {world!r} is neither a built-in world ({', '.join(world_names())}) "
                    f"nor a file in {path.parent}"
                )
            world = str(file)
        worlds.append(world)
    return worlds


def _seeds(value: object, where: str) -> Sequence[int]:
    if isinstance(value, int) and not isinstance(value, bool):
        if value < 1:
            raise ConfigError(f"{where}: a count of seeds must be 1 or more, got {value}")
        if value > MAX_EPISODES:
            raise ConfigError(f"{where}: {value} seeds are more than the {MAX_EPISODES} episodes a sweep runs")
        return range(value)  # 0 .. value - 1, made as they are used
    seeds: list[int] = []
    for seed in _as_list(value, where):
        if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
            raise ConfigError(f"{where}: a seed is a whole number >= 0, got {seed!r}")
        seeds.append(seed)
    if len(set(seeds)) != len(seeds):
        raise ConfigError(f"{where}: a seed is given twice")
    return seeds


def _drivers(value: object, path: Path, per_cell: int) -> list[DriverGrid]:
    """The drivers' grids, their size checked (times `per_cell`: worlds x seeds) before any value is."""
    grids: list[DriverGrid] = []
    entries = _as_list(value, f"{path}: drivers")
    total = 0
    for k, entry in enumerate(entries):
        where = f"{path}: drivers[{k}]"
        if isinstance(entry, str):
            entry = {"driver": entry}
        if not isinstance(entry, dict) or "driver" not in entry:
            raise ConfigError(f"{where}: expected a driver name or a mapping with driver: and params:, got {entry!r}")
        extra = sorted(set(entry) - {"driver", "params"})
        if extra:
            raise ConfigError(f"{where}: unknown field {extra[0]!r} (a driver entry has driver: and params:)")
        driver = entry["driver"]
        try:
            known = driver_parameters(driver)
        except ConfigError as exc:
            raise ConfigError(f"{where}: {exc}") from None
        params = entry.get("params") or {}
        if not isinstance(params, dict):
            raise ConfigError(f"{where}.params: expected a mapping of parameter names to values, got {params!r}")
        grid: dict[str, list[Any]] = {}
        for name, values in params.items():
            if name not in known:
                raise ConfigError(f"{where}.params: {driver} has no parameter {name!r} (it takes: {', '.join(known)})")
            grid[name] = _values(driver, name, values, path, f"{where}.params.{name}")
        checked = DriverGrid(driver, grid)
        total += checked.size
        if total * per_cell > MAX_EPISODES:
            sizes = " + ".join(f"{g.size}" for g in [*grids, checked])
            raise ConfigError(
                f"{where}.params: the grid is {total * per_cell} episodes (worlds x seeds "
                f"{per_cell} x driver combinations {sizes}{' + ...' if k + 1 < len(entries) else ''}), "
                f"more than the {MAX_EPISODES} a sweep runs: sweep fewer values"
            )
        for combination in checked.combinations():
            _check_values(driver, combination, where)
        grids.append(checked)
    return grids


def _values(driver: str, name: str, values: object, path: Path, where: str) -> list[Any]:
    """The values swept for one parameter: a list, or one value; a list-typed parameter takes a list of lists."""
    config = _CONFIGS.get(driver)
    hint = typing.get_type_hints(config).get(name) if config is not None else None
    listed = typing.get_origin(hint) is tuple
    if listed:
        if not (isinstance(values, list) and values and all(isinstance(v, list) for v in values)):  # not swept
            values = [values]
        values = [tuple(v) if isinstance(v, list) else v for v in values]
    values = _as_list(values, where)
    if name == "path":  # a waypoint file, relative to the sweep file
        values = [str(path.parent / v) if isinstance(v, str) and (path.parent / v).is_file() else v for v in values]
    return values


def _check_values(driver: str, params: dict[str, Any], where: str) -> None:
    """Build the driver's settings once here, so that a bad value stops the sweep before any episode runs."""
    try:
        if driver == "wall-follow":
            wall_follow_config(**params)
        elif driver == "pure-pursuit":
            pure_pursuit_config(**{k: v for k, v in params.items() if k != "path"})
            if "path" in params and not Path(str(params["path"])).is_file():
                raise ConfigError(f"path: no such file {params['path']!r}")
        else:
            for name, value in params.items():
                finite_number(value, name)
            if {**CONSTANT_DEFAULTS, **params}["rate"] <= 0:
                raise ConfigError(f"rate: must be positive, got {params['rate']!r}")
    except ConfigError as exc:
        message = str(exc)
        for defaults in DRIVER_DATA.glob("*.yaml"):
            message = message.replace(f"{defaults}: ", "")  # the sweep's value is at fault, not the defaults file
        raise ConfigError(f"{where}.params: {driver}: {message}") from None
