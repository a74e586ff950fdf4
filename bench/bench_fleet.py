"""A fleet in one world: `python bench/bench_fleet.py [--cars 1 2 4 8] [--duration 20] [--repeat 3]`.

Real-time factor of the full pipeline with the lidar on and the camera off (a subscriber on every car's /scan,
since a sensor works only while someone listens) for 1, 2, 4 and 8 cars in the `empty` world, side by side
--gap m apart, each driving its own 1 m/s, 0.2 rad circle (1.6 m radius: the circles never touch) from its own
ConstantCommand node; measured in one run, the best of --repeat, as a table with the ratio to one car and the
car-seconds simulated per wall second. Then the cost of `sim.reset()` for the whole stack (physics, every node's
reset hook, the scheduler), averaged over --resets calls made after a little driving, for 1 and 4 cars.
"""

from __future__ import annotations

import argparse
import time

from racecar_sim import Car, Simulator, Spawn
from racecar_sim.core.names import NAVIGATION
from racecar_sim.drivers import ConstantCommand

GAP = 4.0  # m between neighbours: more than the 3.2 m circles they drive


def fleet(world: str, count: int, gap: float) -> Simulator:
    """`count` cars side by side along y, lidar on, camera off, each driving a circle, every scan listened to."""
    cars = [Car(f"car{k + 1}", spawn=Spawn(0.0, k * gap, 0.05, 0.0), camera=False) for k in range(count)]
    sim = Simulator(world=world, cars=cars)
    for car in sim.cars:
        sim.subscribe(car.lidar.topic, lambda msg: None)
        ConstantCommand(sim.bus, sim.scheduler, 1.0, 0.2, topic=car.topic(NAVIGATION))
    return sim


def fleet_rtf(world: str, count: int, gap: float, duration: float) -> float:
    """Sim seconds per wall second of `count` cars driving for `duration` sim seconds (building excluded)."""
    sim = fleet(world, count, gap)
    start = time.perf_counter()
    sim.run_until(duration)
    wall = time.perf_counter() - start
    sim.close()
    return duration / wall


def reset_cost(world: str, count: int, gap: float, resets: int) -> float:
    """Mean wall seconds of one sim.reset() of `count` cars, each after 0.1 s of driving (not timed)."""
    sim = fleet(world, count, gap)
    total = 0.0
    for _ in range(resets):
        sim.run_for(0.1)
        start = time.perf_counter()
        sim.reset()
        total += time.perf_counter() - start
    sim.close()
    return total / resets


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--world", default="empty")
    p.add_argument("--cars", type=int, nargs="+", default=[1, 2, 4, 8], help="fleet sizes (default 1 2 4 8)")
    p.add_argument("--gap", type=float, default=GAP, help=f"m between neighbours (default {GAP:g})")
    p.add_argument("--duration", type=float, default=20.0, help="sim seconds per measurement (default 20)")
    p.add_argument("--repeat", type=int, default=3, help="measurements per fleet size; the best is kept (default 3)")
    p.add_argument("--resets", type=int, default=500, help="reset() calls averaged (default 500)")
    p.add_argument("--reset-cars", type=int, nargs="+", default=[1, 4], help="fleet sizes for the reset cost")
    args = p.parse_args()

    print(
        f"world {args.world}, lidar on, camera off, each car a 1 m/s circle; {args.duration:g} sim s, "
        f"best of {args.repeat}"
    )
    print(f"{'cars':>4}  {'real-time factor':>16}  {'vs 1 car':>8}  {'car-s per wall s':>16}")
    base = None
    for count in args.cars:
        rtf = max(fleet_rtf(args.world, count, args.gap, args.duration) for _ in range(args.repeat))
        if count == 1:
            base = rtf
        ratio = f"{rtf / base:8.2f}" if base else f"{'-':>8}"
        print(f"{count:>4}  {rtf:>15.1f}x  {ratio}  {rtf * count:>16.1f}")
    print(f"sim.reset(), lidar on, camera off, mean of {args.resets} calls")
    for count in args.reset_cars:
        cost = reset_cost(args.world, count, args.gap, args.resets)
        print(f"{count:>4} car{'s' if count > 1 else ' '}  {cost * 1e6:8.0f} µs")


if __name__ == "__main__":
    main()
