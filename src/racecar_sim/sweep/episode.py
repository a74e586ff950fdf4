"""One episode of a sweep: a Simulator and its driver for the duration, leaving run.mcap and summary.json (and
summary.png if asked) in its folder, and returning the row of the results table."""

from __future__ import annotations

import json
import math
import time
import traceback
from pathlib import Path
from typing import Any

from racecar_sim.core.errors import RacecarSimError
from racecar_sim.core.names import ODOM
from racecar_sim.runtime import Simulator
from racecar_sim.runtime.driving import attach_driver
from racecar_sim.runtime.run_log import RaceLog, RunLog
from racecar_sim.sweep.collisions import race_measures
from racecar_sim.sweep.spec import Episode

MCAP = "run.mcap"
SUMMARY_JSON = "summary.json"
SUMMARY_PNG = "summary.png"


def run_episode(episode: Episode, folder: str | Path) -> dict[str, Any]:
    """Run `episode` into `folder` (created) and return its results row.

    A failure (a spawn pose in a wall, a diverging physics, a bug) does not stop a sweep: the row then carries it
    in `error`, with whatever the episode measured before it. The row is also written to summary.json.
    """
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    settings = episode.settings
    row: dict[str, Any] = {
        "index": episode.index,
        "world": episode.world_label,
        "driver": episode.driver,
        "seed": episode.seed,
        "params": dict(episode.params),
        "duration": settings.duration,
    }
    start = time.perf_counter()
    sim = runlog = race = None
    error = ""
    try:
        sim = Simulator(
            world=episode.world,
            profile=settings.profile,
            seed=episode.seed,
            physics=settings.physics,
            lidar=settings.lidar,
            camera=settings.camera,
            sensor_noise=settings.noise,
        )
        attach_driver(sim, sim.car, episode.driver, episode.params)
        if settings.record:
            sim.record(folder / MCAP)
        runlog = RunLog(
            sim.bus,
            sim.car.lidar.topic if sim.car.lidar else None,
            sim.car.camera.spec.image_topic if sim.car.camera and settings.summary_png else None,
            odom_topic=ODOM,
        )
        race = RaceLog(sim)  # where the crashes and laps happened, for summary.png
        start = time.perf_counter()  # the episode's own time: building the world is not the sim's speed
        sim.run_until(settings.duration)
    except RacecarSimError as exc:
        error = f"{type(exc).__name__}: {' '.join(str(exc).split())}"
    # a bug in one episode must not lose the sweep's other results
    except Exception as exc:
        where = traceback.extract_tb(exc.__traceback__)[-1]
        error = f"{type(exc).__name__}: {' '.join(str(exc).split())} ({where.filename}:{where.lineno})"
    finally:
        wall = time.perf_counter() - start
        if sim is not None:
            sim.close()  # the MCAP's footer
    row.update(_measures(sim, runlog, wall))
    row["error"] = error
    (folder / SUMMARY_JSON).write_text(json.dumps(_json_safe(row), indent=2) + "\n")
    if settings.summary_png and sim is not None and runlog is not None:
        _summary_png(episode, sim, runlog, race, row, folder / SUMMARY_PNG)
    return row


def _measures(sim: Simulator | None, runlog: RunLog | None, wall: float) -> dict[str, Any]:
    sim_time = sim.time if sim is not None else 0.0
    x = y = yaw = math.nan
    if runlog is not None and runlog.last_pose is not None:
        x, y, yaw = runlog.last_pose
    clearance = runlog.min_clearance if runlog is not None and runlog.last_scan is not None else math.nan
    return {
        "sim_time": sim_time,
        "wall_time": wall,
        "real_time_factor": sim_time / wall if wall > 0 else math.nan,
        "distance": runlog.distance if runlog is not None else 0.0,
        "mean_speed": runlog.mean_speed if runlog is not None else 0.0,
        "min_clearance": clearance,
        **race_measures(sim),  # collisions, first_collision_time, laps, best_lap (and their lists)
        "final_x": x,
        "final_y": y,
        "final_yaw": yaw,
    }


def _summary_png(
    episode: Episode, sim: Simulator, runlog: RunLog, race: RaceLog | None, row: dict[str, Any], path: Path
) -> None:
    from racecar_sim.plots.summary import save_summary  # matplotlib loads only when a summary is drawn

    origin = ends = None
    if sim.car.lidar is not None and runlog.last_scan is not None:
        origin, ends = sim.car.lidar.beam_ends(runlog.last_scan.ranges)
    params = ", ".join(f"{k} {v}" for k, v in episode.params.items())
    lines = [
        f"distance         {row['distance']:.1f} m",
        f"mean speed       {row['mean_speed']:.2f} m/s",
        f"collisions       {row['collisions']}",
        *([f"laps             {row['laps']} (best {row['best_lap']:.2f} s)"] if row["laps"] else []),
        f"real-time factor {row['real_time_factor']:.1f}x",
    ]
    if not math.isnan(row["min_clearance"]):
        lines.append(f"min clearance    {row['min_clearance']:.2f} m (lidar)")
    save_summary(
        path,
        sim.world,
        runlog.trajectory,
        scan_origin=None if origin is None else origin[:2],
        scan_points=None if ends is None else ends[:, :2],
        camera_bgr=runlog.last_frame(),
        title=f"{sim.world.name}: {episode.driver} ({params or 'defaults'}), {sim.time:.0f} s sim, seed {episode.seed}",
        lines=lines,
        rate=runlog.trajectory_rate,
        crashes=race.crashes if race is not None else None,
        laps=race.laps if race is not None else None,
        start_line=None if sim.laps is None else (sim.laps.line.a, sim.laps.line.b),
    )


def _json_safe(value: Any) -> Any:
    """Strict JSON: NaN (nothing measured) as null, tuples as lists, numpy scalars as numbers."""
    if isinstance(value, dict):
        return {key: _json_safe(item) for key, item in value.items()}
    if isinstance(value, (list, tuple)):
        return [_json_safe(item) for item in value]
    if hasattr(value, "item"):
        value = value.item()
    return None if isinstance(value, float) and math.isnan(value) else value
