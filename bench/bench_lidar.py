"""Lidar ray casting speed: `python bench/bench_lidar.py [--poses N] [--seed S]`.

For the built-in `tunnel` and `walker`, a generated ROS map with a few hundred walls (written to a temp
folder) and `cones` (five free cone meshes, whose beams are always cast in 3-D), at random poses of the car
among the world's things, tilted as by its suspension (~1e-4 rad): microseconds per 1081-beam scan and rays
per second of the fast caster (2-D footprints, 3-D where needed) and of MuJoCo's 3-D casts (mj_multiRay),
the speed-up, the share of beams the fast caster sent to 3-D, the largest difference between the two (they
must agree), and the one-off cost of cutting the world into footprints. The last column times a whole
published scan (kinematics, casting, noise, float32).
"""

from __future__ import annotations

import argparse
import inspect
import math
import statistics
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

from map_files import write_map
from racecar_sim.core.transforms import quat_from_rpy
from racecar_sim.physics import COLLISION_GROUP, ROOT_JOINT
from racecar_sim.runtime import Simulator
from racecar_sim.sensors.lidar import LidarPublisher

MAP_SIZE, MAP_RESOLUTION = (60.0, 40.0), 0.05  # m, m per cell
SPAWN_INSET = 2.6  # m from the map's lower left corner to the spawn pose, between the walls


def clutter_map(folder: Path, seed: int) -> Path:
    """A ROS map: an outer wall, corridor walls with doorways and scattered blocks (a few hundred boxes)."""
    rng = np.random.default_rng(seed)
    cols, rows = (round(s / MAP_RESOLUTION) for s in MAP_SIZE)
    occupied = np.zeros((rows, cols), bool)
    occupied[:4], occupied[-4:], occupied[:, :4], occupied[:, -4:] = True, True, True, True
    for c in range(100, cols - 50, 100):  # walls every 5 m with two doorways each
        occupied[:, c : c + 3] = True
        for door in rng.integers(20, rows - 40, 2):
            occupied[door : door + 24, c : c + 3] = False
    for _ in range(220):
        r, c = rng.integers(10, rows - 30), rng.integers(10, cols - 30)
        h, w = rng.integers(3, 20, 2)
        occupied[r : r + h, c : c + w] = True
    spawn = round(SPAWN_INSET / MAP_RESOLUTION)  # the world's spawn pose (0, 0) lies SPAWN_INSET m in, kept clear
    occupied[-spawn - 20 : -spawn + 20, spawn - 20 : spawn + 20] = False
    return write_map(folder, "clutter", occupied, MAP_RESOLUTION, (-SPAWN_INSET, -SPAWN_INSET))


def lidar_for(sim: Simulator) -> LidarPublisher:
    lidar = getattr(sim, "lidar", None)
    return lidar or new_lidar(sim)


def new_lidar(sim: Simulator) -> LidarPublisher:
    """A laser node of the car's first ray sensor, built now (the node contract; an older checkout's signature)."""
    if hasattr(sim.car, "context"):
        return LidarPublisher(sim.car.context, sim.car.robot.sensor("ray"))
    return LidarPublisher(sim.bus, sim.scheduler, sim.model, sim.data, sim.car.robot, sim.seed)  # type: ignore[arg-type]


def free_poses(sim: Simulator, lidar: LidarPublisher, count: int, rng: np.random.Generator) -> list[np.ndarray]:
    """qpos vectors with the car somewhere among the world's things, clear of them (judged by a 3-D scan)."""
    car = sim.model.body(sim.car.robot.root).id
    things = sim.data.geom_xpos[sim.model.body_rootid[sim.model.geom_bodyid] != car][:, :2]
    lo, hi = np.percentile(things, 2, axis=0) - 1.0, np.percentile(things, 98, axis=0) + 1.0
    adr = sim.model.jnt_qposadr[sim.model.joint(ROOT_JOINT).id]
    poses = []
    while len(poses) < count:
        qpos = sim.data.qpos.copy()
        qpos[adr : adr + 3] = (*rng.uniform(lo, hi), sim.world.spawn.z - 0.05)
        roll, pitch = rng.normal(0, 1e-4, 2)
        qpos[adr + 3 : adr + 7] = quat_from_rpy((roll, pitch, rng.uniform(-math.pi, math.pi)))
        sim.data.qpos[:] = qpos
        ranges = lidar.caster.cast(*lidar.ray_origin(), mode="3d")
        if np.isfinite(ranges).any() and np.min(ranges) > 0.2:  # sees something, is not inside it
            poses.append(qpos)
    return poses


def time_per_pose(
    sim: Simulator, lidar: LidarPublisher, poses: list[np.ndarray], run: Callable[[np.ndarray, np.ndarray], np.ndarray]
) -> tuple[float, list]:
    """Median over the poses of the best of 5 timings (us) of `run(origin, rotation)`, and its results."""
    times, results = [], []
    for qpos in poses:
        sim.data.qpos[:] = qpos
        origin, rotation = lidar.ray_origin()
        best = math.inf
        for _ in range(5):
            start = time.perf_counter()
            ranges = run(origin, rotation)
            best = min(best, time.perf_counter() - start)
        times.append(best * 1e6)
        results.append(ranges)
    return statistics.median(times), results


def measure(world: str, count: int, seed: int) -> dict[str, float]:
    kwargs = {"camera": False} if "camera" in inspect.signature(Simulator).parameters else {}
    sim = Simulator(world=world, **kwargs)
    start = time.perf_counter()
    lidar = new_lidar(sim)
    build_ms = 1e3 * (time.perf_counter() - start)
    poses = free_poses(sim, lidar, count, np.random.default_rng(seed))
    fast_us, fast = time_per_pose(sim, lidar, poses, lambda o, r: lidar.caster.cast(o, r, mode="auto"))
    shares = []
    for qpos in poses:
        sim.data.qpos[:] = qpos
        lidar.true_ranges()
        shares.append(lidar.caster.last_3d_beams / lidar.fan.count)
    full_us, reference = time_per_pose(sim, lidar, poses, lambda o, r: lidar.caster.cast(o, r, mode="3d"))
    with np.errstate(invalid="ignore"):
        diff = max(
            float(np.max(np.where(np.isinf(a) & np.isinf(b), 0.0, np.abs(a - b)))) for a, b in zip(fast, reference)
        )
    stamps = iter(range(0, 10**12, 25_000_000))
    scan_us, _ = time_per_pose(sim, lidar, poses, lambda o, r: lidar.scan(next(stamps)))
    return {
        "geoms": int((sim.model.geom_group == COLLISION_GROUP).sum()),
        "build_ms": build_ms,
        "fast_us": fast_us,
        "full_us": full_us,
        "diff": diff,
        "share_3d": statistics.mean(shares),
        "scan_us": scan_us,
        "beams": lidar.fan.count,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--poses", type=int, default=100, help="random poses per world (default 100)")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as folder:
        worlds = {
            "tunnel": "tunnel",
            "walker": "walker",
            "map": str(clutter_map(Path(folder), args.seed)),
            "cones": "cones",
        }
        rows = {name: measure(world, args.poses, args.seed) for name, world in worlds.items()}
    print(
        f"{'world':<8}{'geoms':>6}{'build ms':>9}{'fast us':>9}{'fast Mray/s':>12}{'3-D us':>9}{'3-D Mray/s':>11}"
        f"{'speed-up':>9}{'3-D beams':>10}{'max diff m':>11}{'scan us':>9}"
    )
    for name, r in rows.items():
        print(
            f"{name:<8}{r['geoms']:>6}{r['build_ms']:>9.1f}{r['fast_us']:>9.1f}{r['beams'] / r['fast_us']:>12.1f}"
            f"{r['full_us']:>9.1f}{r['beams'] / r['full_us']:>11.2f}{r['full_us'] / r['fast_us']:>8.1f}x"
            f"{100 * r['share_3d']:>9.1f}%{r['diff']:>11.1e}{r['scan_us']:>9.1f}"
        )
    print(
        "fast: 2-D footprints with 3-D where needed (median of per-pose best of 5); 3-D: mj_multiRay, every beam;"
        " scan us: a published scan (kinematics + cast + noise), fast caster"
    )


if __name__ == "__main__":
    main()
