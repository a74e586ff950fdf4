"""The built-in worlds (worlds.yaml beside the SDF files) and loading a world by name or path.

A path is read by its suffix: .world/.sdf → SDF, .yaml/.yml → ROS occupancy map, .csv → race-track centerline.
This is the one place that looks at a world file's suffix: everything else asks the loaded World (its centerline,
World.is_track), or `track_file` for a world named before it is loaded.
"""

from __future__ import annotations

from pathlib import Path

from racecar_sim.core import yaml_text
from racecar_sim.core.errors import WorldError
from racecar_sim.worlds.sdf import load_sdf
from racecar_sim.worlds.world import BUILTIN_DATA, MAX_COORDINATE, Spawn, World

DATA = BUILTIN_DATA
BUILTIN_WORLDS: dict[str, dict] = yaml_text.safe_load((DATA / "worlds.yaml").read_text())
DEFAULT_WALL_HEIGHT = 1.0  # m, walls extruded from maps and track borders
MAP_SUFFIXES = (".yaml", ".yml")
TRACK_SUFFIXES = (".csv",)


def world_names() -> list[str]:
    """Names of the built-in worlds."""
    return list(BUILTIN_WORLDS)


def world_summary(name: str) -> str:
    """One line describing a built-in world."""
    return BUILTIN_WORLDS[name]["summary"]


def _reader(path: Path) -> str:
    """Which loader reads the world file at `path`: "map", "track" or "sdf"."""
    suffix = path.suffix.lower()
    return "map" if suffix in MAP_SUFFIXES else "track" if suffix in TRACK_SUFFIXES else "sdf"


def track_file(name_or_path: str | Path) -> Path | None:
    """The race-track CSV that `name_or_path` loads as (for a world named before it is loaded, as a sweep's list);
    None for a built-in world or a file another loader reads. A loaded World says so itself (World.is_track)."""
    key = str(name_or_path)
    if key in BUILTIN_WORLDS:
        return None
    path = Path(key)
    return path if _reader(path) == "track" and path.is_file() else None


def load_world(
    name_or_path: str | Path,
    spawn: Spawn | None = None,
    model_path: list[Path] | None = None,
    wall_height: float = DEFAULT_WALL_HEIGHT,
) -> World:
    """A built-in world by name, or a world file by path; `spawn` overrides the world's own spawn pose.

    model_path: folders searched for model:// URIs before GAZEBO_MODEL_PATH / GZ_SIM_RESOURCE_PATH and the
    packages on ROS_PACKAGE_PATH (see core.ros_packages.gazebo_model_dirs).
    wall_height: height of the walls extruded from an occupancy map or a track's borders.
    """
    key = str(name_or_path)
    if key in BUILTIN_WORLDS:
        entry = BUILTIN_WORLDS[key]
        world = load_sdf(DATA / entry["file"], model_path)
        x, y, z, yaw = entry["spawn"]
        world.spawn = Spawn(x, y, z, yaw)
        world.name = key
        if "centerline" in entry:
            from racecar_sim.worlds.centerline import read_course_line

            world.centerline = read_course_line(DATA / entry["centerline"])
    else:
        path = Path(name_or_path)
        if not path.exists():
            raise WorldError(f"{key}: no such world file, and not a built-in world ({', '.join(BUILTIN_WORLDS)})")
        if not (wall_height > 0 and wall_height <= MAX_COORDINATE):
            raise WorldError(
                f"{key}: wall height (--wall-height) must be a positive number of metres up to "
                f"{MAX_COORDINATE:g} (the largest world coordinate), got {wall_height:g}"
            )
        reader = _reader(path)
        if reader == "map":
            from racecar_sim.worlds.occupancy_map import load_map

            world = load_map(path, wall_height, spawn)
        elif reader == "track":
            from racecar_sim.worlds.centerline import load_track

            world = load_track(path, wall_height)
        else:
            world = load_sdf(path, model_path)
    if spawn is not None:
        world.spawn = spawn
    world.check_extent()
    return world
