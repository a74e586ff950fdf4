"""Worlds are data: SDF files (built-in ones ship beside this module) loaded into plain `World` objects."""

from racecar_sim.worlds.catalog import BUILTIN_WORLDS, DEFAULT_WALL_HEIGHT, load_world, world_names, world_summary
from racecar_sim.worlds.world import Light, Mesh, Physics, Scene, Spawn, World, WorldBody, WorldGeom

__all__ = ["BUILTIN_WORLDS", "DEFAULT_WALL_HEIGHT", "Light", "Mesh", "Physics", "Scene", "Spawn", "World", "WorldBody",
           "WorldGeom", "load_world", "world_names", "world_summary"]
