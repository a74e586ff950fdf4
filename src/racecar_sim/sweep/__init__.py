"""Sweeps: many episodes over worlds, seeds, drivers and their parameters, on Ray or one by one.

>>> from racecar_sim.sweep import load_sweep, run_sweep
>>> result = run_sweep(load_sweep("examples/sweep_wall_follow.yaml"), "sweeps/wall-follow", num_cpus=4)
>>> result.tables  # [sweeps/wall-follow/results.csv, sweeps/wall-follow/results.parquet]

Ray is imported only when a sweep runs on it (the optional `[ray]` extra); `local=True` needs no Ray.
"""

from racecar_sim.sweep.episode import run_episode
from racecar_sim.sweep.runner import SweepResult, run_sweep
from racecar_sim.sweep.spec import DriverGrid, Episode, SweepSpec, load_sweep

__all__ = ["DriverGrid", "Episode", "SweepResult", "SweepSpec", "load_sweep", "run_episode", "run_sweep"]
