"""Load time and physics speed in each built-in world: `python bench/bench_worlds.py [--duration S]`.

Per world: the time to load the SDF and build the MuJoCo model, the number of geoms, and - driving the car at
1 m/s, 0.2 rad through the full pipeline - physics steps per wall second and the real-time factor. The last
column compares each world's real-time factor to the empty world's in the same run.
"""

from __future__ import annotations

import argparse
import time

from racecar_sim.drivers import ConstantCommand
from racecar_sim.runtime import Simulator
from racecar_sim.worlds import load_world, world_names


def measure(name: str, duration: float) -> dict[str, float]:
    start = time.perf_counter()
    world = load_world(name)
    loaded = time.perf_counter()
    sim = Simulator(world=world)
    built = time.perf_counter()
    ConstantCommand(sim.bus, sim.scheduler, 1.0, 0.2)
    run_start = time.perf_counter()
    sim.run_until(duration)
    wall = time.perf_counter() - run_start
    steps = round(duration / sim.model.opt.timestep)
    return {
        "load_ms": 1e3 * (loaded - start),
        "build_ms": 1e3 * (built - loaded),
        "geoms": sim.model.ngeom,
        "steps_per_s": steps / wall,
        "rtf": duration / wall,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--duration", type=float, default=20.0, help="sim seconds driven per world (default 20)")
    args = parser.parse_args()
    rows = {name: measure(name, args.duration) for name in world_names()}
    base = rows["empty"]["rtf"]
    print(f"{'world':<9}{'load ms':>9}{'build ms':>10}{'geoms':>7}{'steps/s':>10}{'RTF':>8}{'vs empty':>10}")
    for name, r in rows.items():
        print(
            f"{name:<9}{r['load_ms']:>9.1f}{r['build_ms']:>10.1f}{r['geoms']:>7}{r['steps_per_s']:>10.0f}"
            f"{r['rtf']:>7.0f}x{r['rtf'] / base:>10.2f}"
        )


if __name__ == "__main__":
    main()
