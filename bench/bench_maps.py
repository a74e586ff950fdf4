"""Real maps stay fast: `python bench/bench_maps.py [--map FILE.yaml ...] [--duration 5] [--rounds 5]
[--clock cpu|wall]`.

The lidar pipeline (physics, the lidar and every node, camera off, /scan listened to, a ConstantCommand driving
a 1 m/s, 0.2 rad circle) in a ROS occupancy map against the same pipeline in `empty`, as the median of per-round
ratios of real-time factors over --rounds interleaved rounds. The map is of the MIT basement-hallways class:
60 m x 60 m at 5 cm per cell, generated into a temp folder (hallways with one-cell walls, several of them askew
and so drawn in steps, doorways, a room the car circles in, scanner speckle: about 11,000 occupied cells, as
racecar/maps/basement_hallways_5cm.png has), or any map_server YAML given with --map (the car starts at the
map's (0, 0), which must have 2 m of free floor around it). Also printed: occupied cells, colliding geoms in
the model, wall boxes held out of it (physics/near_walls.py), and the bare mj_step time of each model.

Rates are per second of this process's CPU time unless --clock wall (see bench_scaling.py).
Only APIs that exist before issue 14 are used, so `PYTHONPATH=/work/base/src python bench/bench_maps.py`
gives the before figures from the same script.
"""

from __future__ import annotations

import argparse
import itertools
import statistics
import tempfile
from pathlib import Path

import numpy as np
import yaml

import racecar_sim
from bench_scaling import CLOCKS, pipeline_rate, step_us
from machine_info import machine_line
from map_files import write_map
from racecar_sim import Simulator
from racecar_sim.worlds import load_world

RESOLUTION, SIDE = 0.05, 60.0  # m per cell, m
HALL = 2.4  # m, hallway width
ROOM = 9.0  # m, side of the room around the spawn point (the car's circle is 3.2 m across)


def _line(grid: np.ndarray, a: tuple[float, float], b: tuple[float, float]) -> None:
    """Mark the cells on the segment a-b (metres from the map centre, y up) as one-cell, 8-connected steps."""
    rows = grid.shape[0]
    (x0, y0), (x1, y1) = ((np.asarray(p) + SIDE / 2) / RESOLUTION for p in (a, b))
    n = int(max(abs(x1 - x0), abs(y1 - y0))) + 1
    cols = np.rint(np.linspace(x0, x1, n)).astype(int)
    lines = rows - 1 - np.rint(np.linspace(y0, y1, n)).astype(int)
    keep = (cols >= 0) & (cols < grid.shape[1]) & (lines >= 0) & (lines < rows)
    grid[lines[keep], cols[keep]] = True


def _hallway(grid: np.ndarray, points: list[tuple[float, float]], doors: np.random.Generator) -> None:
    """Both walls of a hallway along a centre polyline, HALL apart, with a 1 m doorway here and there."""
    for (ax, ay), (bx, by) in itertools.pairwise(points):
        length = np.hypot(bx - ax, by - ay)
        nx, ny = -(by - ay) / length, (bx - ax) / length
        for side in (-0.5, 0.5):
            start = np.array([ax + side * HALL * nx, ay + side * HALL * ny])
            step = np.array([bx - ax, by - ay]) / length
            cut = doors.uniform(0.2, 0.8) * length if length > 6 and doors.random() < 0.6 else None
            if cut is None:
                _line(grid, tuple(start), tuple(start + length * step))
            else:
                _line(grid, tuple(start), tuple(start + cut * step))
                _line(grid, tuple(start + (cut + 1.0) * step), tuple(start + length * step))


def basement_like(folder: Path, seed: int) -> Path:
    """Write a basement-hallways-class map (PGM + YAML) into `folder`; the spawn point (0, 0) is in its room."""
    rng = np.random.default_rng(seed)
    cells = round(SIDE / RESOLUTION)
    grid = np.zeros((cells, cells), bool)
    h = ROOM / 2
    for a, b in [
        ((-h, -h), (h, -h)),
        ((h, -h), (h, -1.0)),
        ((h, 1.0), (h, h)),
        ((h, h), (-h, h)),
        ((-h, h), (-h, 1.0)),
        ((-h, -1.0), (-h, -h)),
    ]:  # the room, doorways east and west
        _line(grid, a, b)
    hallways = [
        [(h, 0.0), (14.0, 0.0), (14.5, 12.0), (22.0, 20.0)],  # east, then slightly askew north, then 45 degrees
        [(-h, 0.0), (-12.0, 0.4), (-20.0, -8.0), (-20.5, -24.0)],  # west, a 3 degree skew, then askew south
        [(14.0, 0.0), (14.0, -20.0), (-6.0, -21.0), (-20.5, -24.0)],  # south and back west: a loop
        [(14.5, 12.0), (-2.0, 13.0), (-12.0, 24.0)],  # north-west, askew
        [(-20.0, -8.0), (-26.0, 5.0), (-12.0, 24.0), (10.0, 26.0)],  # the far side, askew at 25 and 50 degrees
    ]
    for points in hallways:
        _hallway(grid, points, rng)
    speckle = rng.integers(0, cells, (350, 2))  # scanner noise: single cells, mostly near walls in real maps
    grid[speckle[:, 0], speckle[:, 1]] = True
    for r, c in rng.integers(0, cells - 8, (60, 2)):  # furniture and people: small blobs
        grid[r : r + rng.integers(2, 7), c : c + rng.integers(2, 7)] = True
    centre = cells // 2
    clear = round(3.0 / RESOLUTION)
    grid[centre - clear : centre + clear, centre - clear : centre + clear] = False  # nothing on the car's circle
    return write_map(folder, "basement_like", grid, RESOLUTION, (-SIDE / 2, -SIDE / 2))


def occupied_count(path: Path) -> int:
    """Occupied cells of a map_server map, as the loader reads them: the area its walls cover."""
    resolution = float(yaml.safe_load(path.read_text())["resolution"])
    walls = load_world(path).bodies[-1]
    return round(sum(g.size[0] * g.size[1] for g in walls.geoms if g.collides) / resolution**2)


def collision_geoms(world: str) -> tuple[int, int]:
    """Colliding geoms in the model (what MuJoCo's collision visits) and wall boxes held out of it as data (issue
    14's near walls; 0 before)."""
    sim = Simulator(world=world, camera=False)
    model = sim.model
    in_model = int(((model.geom_contype != 0) | (model.geom_conaffinity != 0)).sum())
    try:
        from racecar_sim.physics.near_walls import WallBoxes
    except ImportError:  # the code before issue 14
        held = None
    else:
        held = WallBoxes.of(model)
    sim.close()
    return in_model, 0 if held is None else len(held)


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--map", nargs="*", default=[], help="map_server YAML files to add to the generated map")
    p.add_argument("--duration", type=float, default=5.0, help="sim seconds per measurement (default 5)")
    p.add_argument("--rounds", type=int, default=5, help="interleaved rounds; medians are reported (default 5)")
    p.add_argument("--seed", type=int, default=0, help="seed of the generated map")
    p.add_argument(
        "--clock",
        choices=tuple(CLOCKS),
        default="cpu",
        help="cpu: this process's CPU time (default; steady on a shared machine), wall: elapsed time",
    )
    args = p.parse_args()
    print(machine_line(), flush=True)  # absolute figures belong to a machine
    print(
        f"racecar_sim from {Path(racecar_sim.__file__).parent}; lidar pipeline, camera off, {args.duration:g} sim s "
        f"per measurement, medians of {args.rounds} interleaved rounds, {args.clock} time"
    )
    with tempfile.TemporaryDirectory() as folder:
        maps = {"basement-like (generated)": basement_like(Path(folder), args.seed)}
        maps.update({Path(m).name: Path(m).resolve() for m in args.map})
        load_world(next(iter(maps.values())))  # the loader's imports, out of the first timing
        worlds = {"empty": "empty", **{name: str(path) for name, path in maps.items()}}
        rates: dict[str, list[float]] = {name: [] for name in worlds}
        for _ in range(args.rounds):
            for name, world in worlds.items():
                rates[name].append(
                    pipeline_rate(lambda w=world: Simulator(world=w, camera=False), args.duration, args.clock)
                )
        print(
            f"{'world':<28}{'cells':>8}{'geoms':>7}{'held':>6}{'mj_step us':>11}{'real-time factor':>18}"
            f"{'vs empty':>10}"
        )
        for name, world in worlds.items():
            cells = occupied_count(maps[name]) if name in maps else 0
            ratio = statistics.median(a / b for a, b in zip(rates[name], rates["empty"]))
            step = step_us(lambda w=world: Simulator(world=w, camera=False), clock=args.clock)
            rate = statistics.median(rates[name])
            geoms, held = collision_geoms(world)
            print(f"{name:<28}{cells:>8}{geoms:>7}{held:>6}{step:>11.1f}{rate:>17.1f}x{ratio:>10.2f}")
    print(
        "geoms: colliding geoms in the MuJoCo model (the car's 6, the ground plane and the near-wall slots in use at "
        "the start); held: map wall boxes kept as data, placed in slots near the car (physics/near_walls.py)"
    )


if __name__ == "__main__":
    main()
