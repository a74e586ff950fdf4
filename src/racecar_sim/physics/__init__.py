"""Physics: the MuJoCo model built from the description and a world, and its presets."""

from racecar_sim.physics.builder import ROOT_JOINT, build_spec
from racecar_sim.physics.world_geoms import COLLISION_GROUP, VISUAL_GROUP
from racecar_sim.physics.presets import PhysicsPreset, load_preset, preset_names

__all__ = ["COLLISION_GROUP", "ROOT_JOINT", "VISUAL_GROUP", "PhysicsPreset", "build_spec", "load_preset", "preset_names"]
