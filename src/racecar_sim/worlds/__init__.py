"""Worlds are data: SDF files (built-in ones ship beside this module) loaded into plain `World` objects."""

from racecar_sim.worlds.catalog import BUILTIN_WORLDS, load_world, world_names
from racecar_sim.worlds.world import Light, Physics, Spawn, World, WorldBody, WorldGeom

__all__ = ["BUILTIN_WORLDS", "Light", "Physics", "Spawn", "World", "WorldBody", "WorldGeom", "load_world", "world_names"]
