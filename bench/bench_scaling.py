"""How the lidar pipeline scales: `python bench/bench_scaling.py [--duration 5] [--rounds 3] [--only beams geoms cars]
[--clock cpu|wall]`.

The pipeline is physics, the lidar and every node with the camera off, a subscriber on each /scan (a sensor
works only while someone listens) and a ConstantCommand per car driving a 1 m/s, 0.2 rad circle (1.6 m radius).
Its real-time factor is printed against
  - beams: the Hokuyo's sample count (270, 540, 1081, 2161) in `tunnel`, where every beam meets a wall; the
    count is read from racecar.gazebo, so each case runs a copy of the xacro whose <samples> is changed;
  - geoms: static boxes (0, 100, 1000, 4000; 0.2 m x 0.2 m x 1 m, a collision box and its visual copy each)
    scattered over 60 m x 60 m of the `empty` world, none within 4 m of the car's circle: geometry that
    never touches the car, though the lidar sees the near ones;
  - cars: fleets of 1, 2, 4 and 8 in `empty`, 4 m apart, each with its lidar (car-seconds per wall second too).
Each row also gives the ratio to the first row of its table and the bare mj_step time of its model, so a
regression shows as a ratio. Cases are interleaved over --rounds rounds and each ratio is the median of
per-round ratios; rates are per second of this process's CPU time unless --clock wall, so that other
processes on a shared machine move them little.

Only APIs that exist before issue 14 are used (Simulator, Car, load_world, ConstantCommand, box_geoms), so
`PYTHONPATH=/work/base/src python bench/bench_scaling.py` gives the before figures from the same script.
"""

from __future__ import annotations

import argparse
import re
import statistics
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

import mujoco
import numpy as np

import racecar_sim
from machine_info import machine_line
from racecar_sim import Car, Simulator, Spawn
from racecar_sim.core.names import NAVIGATION
from racecar_sim.description import DEFAULT_XACRO
from racecar_sim.drivers import ConstantCommand
from racecar_sim.worlds import load_world
from racecar_sim.worlds.walls import box_geoms
from racecar_sim.worlds.world import World, WorldBody

SPEED, STEER = 1.0, 0.2  # m/s, rad: a 1.6 m circle
BEAMS = (270, 540, 1081, 2161)
GEOMS = (0, 100, 1000, 4000)
CARS = (1, 2, 4, 8)
GAP = 4.0  # m between cars: more than the 3.2 m circles they drive
FIELD, CLEAR = 60.0, 6.0  # m: side of the square the boxes lie in, and the radius kept free around the circle
STEER_CENTRE_Y = 1.6  # m: the circle's centre lies this far to the car's left (+y) of the spawn point
BOX = (0.2, 0.2, 1.0)  # m


def drive(sim: Simulator) -> Simulator:
    """Every car of `sim` listened to on /scan and driving the circle."""
    for car in sim.cars:
        sim.subscribe(car.lidar.topic, lambda msg: None)
        ConstantCommand(sim.bus, sim.scheduler, SPEED, STEER, topic=car.topic(NAVIGATION))
    return sim


CLOCKS = {"cpu": time.process_time, "wall": time.perf_counter}


def pipeline_rate(make: Callable[[], Simulator], duration: float, clock: str = "cpu") -> float:
    """Sim seconds per second of `clock` of a freshly built pipeline over `duration` sim seconds (building excluded).

    clock "cpu" counts this process's CPU time (all its threads), so other processes on a shared machine move it
    little; "wall" counts elapsed time. The pipeline is one thread, so on an idle machine they agree.
    """
    sim = drive(make())
    sim.run_until(0.2)  # the first scans and messages build caches; not what a long run costs
    now = CLOCKS[clock]
    start = now()
    sim.run_until(0.2 + duration)
    spent = now() - start
    sim.close()
    return duration / spent


def step_us(make: Callable[[], Simulator], steps: int = 2000, clock: str = "cpu") -> float:
    """Bare mj_step of the model, microseconds per step (best of 3), the car rolling."""
    sim = make()
    model, data = sim.model, sim.data
    data.ctrl[:] = 0.3
    mujoco.mj_step(model, data, nstep=100)
    best, now = float("inf"), CLOCKS[clock]
    for _ in range(3):
        start = now()
        mujoco.mj_step(model, data, nstep=steps)
        best = min(best, (now() - start) / steps)
    sim.close()
    return best * 1e6


def lidar_xacro(folder: Path, samples: int) -> Path:
    """A copy of the racecar xacro whose Hokuyo has `samples` beams (racecar.gazebo rewritten beside it)."""
    urdf = Path(DEFAULT_XACRO).parent
    gazebo = (urdf / "racecar.gazebo").read_text()
    gazebo, found = re.subn(r"<samples>\d+</samples>", f"<samples>{samples}</samples>", gazebo, count=1)
    if not found:
        raise SystemExit(f"{urdf / 'racecar.gazebo'}: no <samples> element to change")
    (folder / f"racecar_{samples}.gazebo").write_text(gazebo)
    xacro = (
        (urdf / "racecar.xacro")
        .read_text()
        .replace("$(find racecar_description)/urdf/racecar.gazebo", str(folder / f"racecar_{samples}.gazebo"))
    )
    path = folder / f"racecar_{samples}.xacro"
    path.write_text(xacro)
    return path


def scattered_boxes(count: int, seed: int = 0) -> World:
    """The `empty` world with `count` static boxes (collision + visual) scattered clear of the car's circle."""
    world = load_world("empty")
    if count == 0:
        return world
    rng = np.random.default_rng(seed)
    centres = np.zeros((0, 2))
    while len(centres) < count:
        xy = rng.uniform(-FIELD / 2, FIELD / 2, (2 * count, 2))
        centres = np.r_[centres, xy[np.hypot(xy[:, 0], xy[:, 1] - STEER_CENTRE_Y) > CLEAR]][:count]
    z = np.full((count, 1), BOX[2] / 2)
    geoms = box_geoms("clutter", np.c_[centres, z], np.tile(BOX, (count, 1)), rng.uniform(0, np.pi, count))
    world.bodies.append(WorldBody("clutter", np.zeros(3), np.array([1.0, 0.0, 0.0, 0.0]), static=True, geoms=geoms))
    return world


def fleet(count: int) -> Simulator:
    """`count` cars side by side along y in `empty`, lidar on, camera off."""
    return Simulator(
        world="empty",
        cars=[Car(f"car{k + 1}", spawn=Spawn(0.0, k * GAP, 0.05, 0.0), camera=False) for k in range(count)],
    )


def measure(
    cases: dict[str, Callable[[], Simulator]], duration: float, rounds: int, clock: str
) -> dict[str, dict[str, float]]:
    """Per case: median real-time factor, median ratio to the first case (per round), and mj_step us."""
    rates: dict[str, list[float]] = {name: [] for name in cases}
    for _ in range(rounds):
        for name, make in cases.items():
            rates[name].append(pipeline_rate(make, duration, clock))
    first = next(iter(cases))
    return {
        name: {
            "rtf": statistics.median(r),
            "ratio": statistics.median(a / b for a, b in zip(r, rates[first])),
            "step_us": step_us(make, clock=clock),
        }
        for (name, make), r in zip(cases.items(), rates.values())
    }


def table(
    title: str,
    label: str,
    rows: dict[str, dict[str, float]],
    extra: Callable[[str, dict], str] | None = None,
    extra_head: str = "",
) -> None:
    print(f"\n{title}")
    print(f"{label:>12}  {'real-time factor':>16}  {'vs first':>8}  {'mj_step us':>10}  {extra_head}")
    for name, r in rows.items():
        print(
            f"{name:>12}  {r['rtf']:>15.1f}x  {r['ratio']:>8.2f}  {r['step_us']:>10.1f}  "
            f"{extra(name, r) if extra else ''}"
        )


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--duration", type=float, default=5.0, help="sim seconds per measurement (default 5)")
    p.add_argument("--rounds", type=int, default=3, help="interleaved rounds; medians are reported (default 3)")
    p.add_argument("--only", nargs="+", choices=("beams", "geoms", "cars"), default=["beams", "geoms", "cars"])
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
    if "beams" in args.only:
        with tempfile.TemporaryDirectory() as folder:
            xacros = {n: lidar_xacro(Path(folder), n) for n in BEAMS}
            cases = {str(n): (lambda x=x: Simulator(world="tunnel", camera=False, xacro=x)) for n, x in xacros.items()}
            table("lidar beams (tunnel)", "beams", measure(cases, args.duration, args.rounds, args.clock))
    if "geoms" in args.only:
        cases = {str(n): (lambda n=n: Simulator(world=scattered_boxes(n), camera=False)) for n in GEOMS}
        table(
            "static boxes in empty (collision + visual each)",
            "boxes",
            measure(cases, args.duration, args.rounds, args.clock),
        )
    if "cars" in args.only:
        cases = {str(n): (lambda n=n: fleet(n)) for n in CARS}
        table(
            "cars in empty",
            "cars",
            measure(cases, args.duration, args.rounds, args.clock),
            lambda name, r: f"{r['rtf'] * int(name):.1f}",
            "car-s per wall s",
        )


if __name__ == "__main__":
    main()
