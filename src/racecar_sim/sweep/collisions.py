"""An episode's crashes and laps for its results row, from the Simulator's own crash watch (`sim.collisions`: walls,
obstacles and cars, each crash once, with its sim time and what was hit) and lap counter (`sim.laps`), the figures
`racecar-sim run` prints and writes to summary.json."""

from __future__ import annotations

import math
from typing import Any

from racecar_sim.runtime import Simulator
from racecar_sim.runtime.run_log import race_results


def race_measures(sim: Simulator | None) -> dict[str, Any]:
    """The first car's `collisions` (how many crashes), `first_collision_time` (s, NaN without one), `laps` (None in
    a world without a start line), `best_lap` (s, NaN without a lap), and the lists behind them (`lap_times`,
    `crashes`: sim time, what was hit, kind) for summary.json."""
    if sim is None:
        return {"collisions": 0, "first_collision_time": math.nan, "laps": None, "best_lap": math.nan}
    results = race_results(sim, sim.car.model_name)
    crashes = results["crashes"]
    return {
        "collisions": results["crash_count"],
        "first_collision_time": crashes[0]["time"] if crashes else math.nan,
        "laps": results["laps"],
        "best_lap": results["best_lap"] if results["best_lap"] is not None else math.nan,
        "lap_times": results["lap_times"],
        "crashes": crashes,
    }
