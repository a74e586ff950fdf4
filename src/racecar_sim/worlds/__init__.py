"""Worlds are data: SDF files (built-in ones ship beside this module) loaded into plain `World` objects."""

from racecar_sim.worlds.catalog import (
    BUILTIN_WORLDS,
    DEFAULT_WALL_HEIGHT,
    load_world,
    track_file,
    world_names,
    world_summary,
)
from racecar_sim.worlds.row import CAR_SPACING, row_centerline, starting_row
from racecar_sim.worlds.world import Centerline, Light, Mesh, Physics, Scene, Spawn, World, WorldBody, WorldGeom

__all__ = [
    "BUILTIN_WORLDS",
    "CAR_SPACING",
    "DEFAULT_WALL_HEIGHT",
    "Centerline",
    "Light",
    "Mesh",
    "Physics",
    "Scene",
    "Spawn",
    "World",
    "WorldBody",
    "WorldGeom",
    "load_world",
    "row_centerline",
    "starting_row",
    "track_file",
    "world_names",
    "world_summary",
]
