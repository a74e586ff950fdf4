"""The lidar pipeline against bare physics: `python bench/bench_pipeline.py [--duration S] [--rounds N]`.

For `tunnel` and `walker`: the whole no-camera pipeline (physics, lidar, every node of the stack, the wall-follow
driver attached as `racecar-sim run` attaches it, a /scan subscriber) and bare MuJoCo `mj_step` of the same model
for the same steps (a replay of the pipeline's own actuator controls, chunk by chunk: the same trajectory),
interleaved round by round. Printed: both real-time factors and the median of the per-round ratios (pipeline /
bare); the wall-follow driver's microseconds per scan, whole and its wall fit alone (on the scans of a run); then a
split of one pipeline run by node (exclusive wall time of each scheduler task and bus callback, mj_step apart; the
timing itself adds ~0.5 us per callback, which lands in the last line).

Uses only the Simulator, attach_driver, the bus's and scheduler's public methods and the driver's _on_scan and
_wall, all present before issue 14 too, so that the same script measures an older tree:
`PYTHONPATH=/path/to/src python bench/bench_pipeline.py`.
"""

from __future__ import annotations

import argparse
import statistics
import time
from collections import defaultdict
from collections.abc import Callable
from typing import Any

import mujoco
import numpy as np

from machine_info import machine_line
from racecar_sim.bus import Bus
from racecar_sim.drivers import WallFollower
from racecar_sim.runtime import Simulator
from racecar_sim.runtime.driving import attach_driver
from racecar_sim.runtime.scheduler import Scheduler

WORLDS = ("tunnel", "walker")


def pipeline(world: str) -> tuple[Simulator, WallFollower]:
    """The lidar pipeline as `racecar-sim run --no-camera --no-record` builds it, and its driver."""
    sim = Simulator(world=world, camera=False)
    driver = attach_driver(sim, sim.car, "wall-follow", {})
    sim.subscribe(sim.car.lidar.topic, lambda msg: None)
    return sim, driver


def pipeline_seconds(world: str, duration: float) -> tuple[float, int, mujoco.MjModel]:
    """Wall seconds of `duration` sim seconds of the pipeline, its physics steps and its model."""
    sim, _ = pipeline(world)
    start = time.perf_counter()
    sim.run_until(duration)
    wall = time.perf_counter() - start
    steps = sim.time_ns // sim.step_ns
    model = sim.model
    sim.close()
    return wall, steps, model


def bare_seconds(model: mujoco.MjModel, controls: list[tuple[int, np.ndarray]]) -> float:
    """Wall seconds of bare mj_step replaying a pipeline run's physics: the same steps in the same chunks, under the
    same actuator controls (MuJoCo is deterministic, so it is the very same trajectory), no Python in between."""
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    step = mujoco.mj_step
    start = time.perf_counter()
    for nstep, ctrl in controls:
        data.ctrl[:] = ctrl
        step(model, data, nstep=nstep)
    return time.perf_counter() - start


def ratios(world: str, duration: float, rounds: int, controls: list[tuple[int, np.ndarray]]) -> dict[str, float]:
    """Median over interleaved rounds of pipeline and bare real-time factors and of their ratio."""
    pipe, bare, ratio = [], [], []
    for _ in range(rounds):
        wall, steps, model = pipeline_seconds(world, duration)
        if steps != sum(n for n, _ in controls):
            raise RuntimeError(f"{world}: the pipeline stepped {steps} times, the replay {sum(n for n, _ in controls)}")
        bare_wall = bare_seconds(model, controls)
        pipe.append(duration / wall)
        bare.append(duration / bare_wall)
        ratio.append(bare_wall / wall)
    return {"pipeline": statistics.median(pipe), "bare": statistics.median(bare), "ratio": statistics.median(ratio)}


class NodeClock:
    """Exclusive wall time per callback: a callback's time less that of the callbacks it set off (depth-first)."""

    def __init__(self) -> None:
        self.seconds: dict[str, float] = defaultdict(float)
        self.calls: dict[str, int] = defaultdict(int)
        self._stack: list[float] = []  # per open callback: time already given to callbacks nested in it

    def wrap(self, label: str, callback: Callable[..., Any]) -> Callable[..., Any]:
        stack, seconds, calls, clock = self._stack, self.seconds, self.calls, time.perf_counter

        def timed(*args: Any, **kw: Any) -> Any:
            stack.append(0.0)
            start = clock()
            try:
                return callback(*args, **kw)
            finally:
                spent = clock() - start
                nested = stack.pop()
                seconds[label] += spent - nested
                calls[label] += 1
                if stack:
                    stack[-1] += spent

        return timed


def label_of(callback: Callable[..., Any], fallback: str) -> str:
    name = getattr(callback, "__qualname__", "") or fallback
    return fallback if "<lambda>" in name else name.replace(".<locals>", "")


def node_split(world: str, duration: float) -> tuple[dict[str, float], dict[str, int], float, list[Any], list]:
    """(exclusive seconds per node, calls per node, wall seconds, the scans published, the (steps, controls) of each
    mj_step call) of one pipeline run."""
    pipeline_seconds(world, 1.0)  # warm: compiled kernels loaded, caches filled
    clock = NodeClock()
    subscribe, every = Bus.subscribe, Scheduler.every

    def timed_subscribe(bus: Bus, topic: str, callback: Callable[[Any], None], *args: Any, **kw: Any) -> Any:
        return subscribe(bus, topic, clock.wrap(label_of(callback, f"sub {topic}"), callback), *args, **kw)

    def timed_every(
        scheduler: Scheduler, rate: float, callback: Callable[[int], None], name: str, *args: Any, **kw: Any
    ) -> Any:
        return every(scheduler, rate, clock.wrap(label_of(callback, f"timer {name}"), callback), name, *args, **kw)

    step = mujoco.mj_step
    Bus.subscribe, Scheduler.every = timed_subscribe, timed_every  # type: ignore[method-assign]
    try:
        sim, _ = pipeline(world)
        scans: list[Any] = []
        sim.subscribe(sim.car.lidar.topic, scans.append)
        controls: list[tuple[int, np.ndarray]] = []
        timed_step = clock.wrap("mj_step", step)

        def recorded_step(model: mujoco.MjModel, data: mujoco.MjData, nstep: int = 1) -> None:
            controls.append((nstep, data.ctrl.copy()))
            timed_step(model, data, nstep=nstep)

        mujoco.mj_step = recorded_step
        start = time.perf_counter()
        sim.run_until(duration)
        wall = time.perf_counter() - start
    finally:
        Bus.subscribe, Scheduler.every, mujoco.mj_step = subscribe, every, step  # type: ignore[method-assign]
    sim.close()
    return dict(clock.seconds), dict(clock.calls), wall, scans, controls


def driver_us(scans: list[Any], repeat: int = 5) -> tuple[float, float]:
    """Microseconds per scan of the wall-follow driver on `scans`, whole and its wall fit alone: per scan the best of
    `repeat` passes (a fresh driver each, so each pass takes the same decisions), then the median over the scans
    (robust to the machine's other work)."""
    inputs = []
    for scan in scans:
        ranges = np.nan_to_num(np.asarray(scan.ranges, np.float64), posinf=scan.range_max, neginf=scan.range_max)
        inputs.append((ranges, scan.angle_min + scan.angle_increment * np.arange(len(ranges))))
    whole, wall = np.full(len(scans), np.inf), np.full(len(scans), np.inf)
    clock = time.perf_counter
    for _ in range(repeat):
        driver = WallFollower(Bus())
        for k, scan in enumerate(scans):
            start = clock()
            driver._on_scan(scan)
            whole[k] = min(whole[k], clock() - start)
        angles = inputs[0][1]  # one layout: the same array each time, as the driver's own scans give it
        for k, (ranges, _) in enumerate(inputs):
            start = clock()
            driver._wall(ranges, angles)
            wall[k] = min(wall[k], clock() - start)
    return float(np.median(whole)) * 1e6, float(np.median(wall)) * 1e6


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--duration", type=float, default=20.0, help="sim seconds per run (default 20)")
    parser.add_argument("--rounds", type=int, default=3, help="interleaved pipeline/bare rounds (default 3)")
    parser.add_argument("--worlds", nargs="+", default=list(WORLDS))
    args = parser.parse_args()
    print(machine_line(), flush=True)  # absolute figures belong to a machine
    print(
        f"lidar pipeline (camera off, wall-follow) vs bare mj_step; {args.duration:g} sim s, "
        f"median of {args.rounds} interleaved rounds"
    )
    print(f"{'world':<8}{'pipeline x':>11}{'bare x':>9}{'ratio':>7}{'scan us':>9}{'_wall us':>9}")
    splits = {}
    for world in args.worlds:
        seconds, calls, wall, scans, controls = node_split(world, args.duration)
        r = ratios(world, args.duration, args.rounds, controls)
        splits[world] = (seconds, calls, wall)
        scan_us, wall_us = driver_us(scans)
        print(f"{world:<8}{r['pipeline']:>10.1f}x{r['bare']:>8.1f}x{r['ratio']:>7.2f}{scan_us:>9.1f}{wall_us:>9.1f}")
    for world, (seconds, calls, wall) in splits.items():
        print(f"\n{world}: exclusive share of the pipeline's wall time ({wall:.2f} s, timed run), us per call")
        rest = wall - sum(seconds.values())
        for label, s in sorted(seconds.items(), key=lambda kv: -kv[1]):
            print(f"  {label:<52}{100 * s / wall:6.1f}%{1e6 * s / calls[label]:9.1f} us x {calls[label]}")
        print(f"  {'(run loop, scheduler, bus outside callbacks)':<52}{100 * rest / wall:6.1f}%")


if __name__ == "__main__":
    main()
