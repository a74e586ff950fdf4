"""The built-in worlds (worlds.yaml beside the SDF files) and loading a world by name or path."""

from __future__ import annotations

from importlib import resources
from pathlib import Path

import yaml

from racecar_sim.core.errors import WorldError
from racecar_sim.worlds.sdf import load_sdf
from racecar_sim.worlds.world import Spawn, World

DATA = Path(str(resources.files("racecar_sim.worlds") / "data"))
BUILTIN_WORLDS: dict[str, dict] = yaml.safe_load((DATA / "worlds.yaml").read_text())


def world_names() -> list[str]:
    """Names of the built-in worlds."""
    return list(BUILTIN_WORLDS)


def load_world(name_or_path: str, spawn: Spawn | None = None) -> World:
    """A built-in world by name, or an SDF .world/.sdf file by path; `spawn` overrides the world's own spawn pose."""
    if name_or_path in BUILTIN_WORLDS:
        entry = BUILTIN_WORLDS[name_or_path]
        world = load_sdf(DATA / entry["file"])
        x, y, z, yaw = entry["spawn"]
        world.spawn = Spawn(x, y, z, yaw)
        world.name = name_or_path
    else:
        path = Path(name_or_path)
        if not path.exists():
            raise WorldError(f"{name_or_path}: no such world (built-in worlds: {', '.join(BUILTIN_WORLDS)})")
        world = load_sdf(path)
    if spawn is not None:
        world.spawn = spawn
    return world
