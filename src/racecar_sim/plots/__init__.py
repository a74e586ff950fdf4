"""Plots with matplotlib (Agg, no pyplot): top-down maps of worlds, later trajectories drawn on them."""

from racecar_sim.plots.world_map import draw_spawn, draw_world, save_world_png, world_extent, world_figure

__all__ = ["draw_spawn", "draw_world", "save_world_png", "world_extent", "world_figure"]
