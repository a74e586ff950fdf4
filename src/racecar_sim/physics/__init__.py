"""Physics: the MuJoCo model built from the description and a world (builder.py), the scene that owns its MjSpec
through build, compile and recompile (scene.py), the map walls held near the cars, presets, spawn checks and state
access."""

from racecar_sim.physics.builder import (
    ROOT_JOINT,
    add_car,
    build_spec,
    fit_near_walls,
    route_mujoco_warnings,
    world_spec,
)
from racecar_sim.physics.near_walls import NearWalls, WallBoxes
from racecar_sim.physics.presets import PhysicsPreset, load_preset, preset_names
from racecar_sim.physics.spawn_check import check_spawn
from racecar_sim.physics.world_geoms import COLLISION_GROUP, VISUAL_GROUP

__all__ = [
    "COLLISION_GROUP",
    "ROOT_JOINT",
    "VISUAL_GROUP",
    "NearWalls",
    "PhysicsPreset",
    "WallBoxes",
    "add_car",
    "build_spec",
    "check_spawn",
    "fit_near_walls",
    "load_preset",
    "preset_names",
    "route_mujoco_warnings",
    "world_spec",
]
