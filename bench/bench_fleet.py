"""Fleets against bare MuJoCo: `python bench/bench_fleet.py [--cars 1 2 4 8] [--worlds empty tunnel] [--track-cars 30]
[--duration 10] [--rounds 3] [--cli-cars 1 4 8] [--cli-worlds empty tunnel track] [--cli-track-cars 30]
[--cli-recording both] [--quick]`.

Per fleet: the pipeline - physics, every node of every car, the lidar on and the camera off, a subscriber on every
/scan (a sensor works only while someone listens), each car driven by its own driver node - and bare MuJoCo `mj_step`
of the same N-car model replaying the pipeline's own actuator controls chunk by chunk (MuJoCo is deterministic: the
very same trajectory, contacts included), interleaved round by round; both are timed after the first 0.5 sim s (the
one-time costs of a first scan: loading the compiled kernels, slicing the world). The fleets:
  - empty:  N cars side by side, 4 m apart, each a ConstantCommand 1 m/s, 0.2 rad circle (the circles never touch);
  - tunnel: N cars in a row 1.5 m apart, as `racecar-sim run --world tunnel --cars N` places them, wall-follow each;
  - track:  --track-cars (default 30) cars in a row round a generated oval track CSV (98 m of centerline, 2.4 m
            wide), as `racecar-sim run --world TRACK.csv --cars N` places them, pure-pursuit each on the centerline.
Printed per fleet: the real-time factor, bare MuJoCo's on the same model, the median of the per-round ratios (pipeline
/ bare), and car-seconds simulated per wall second (the real-time factor times N). Then the CLI as users run it:
`racecar-sim run --world empty --cars N --driver constant --speed 1 --no-camera --no-video --no-summary --duration D`
(--cli-cars, --cli-duration; --no-record, and with the recording on: --cli-recording; --cli-worlds adds the tunnel,
wall-follow each, and the oval track, pure-pursuit each, in the CLI's rows; on the track --cli-track-cars too), a
fresh process timed from start to exit (its start-up and one-time costs included), against bare mj_step of the same
N-car model replaying the same run's controls from the start (recorded from the same fleet built in-process: the CLI's
row, its drivers); beside it the loop ratio, bare MuJoCo against the run loop alone (the sim time over the real-time
factor the CLI prints: start-up, the build and the exit left out), the wall seconds outside the loop, and bare MuJoCo
as a whole process too (`python -c`: import mujoco, compile the model's XML, set the replay's wheel commands, step:
its one-time costs included, as the CLI's are) with the CLI's ratio to it, in wall time and in CPU time (the
processes' own CPU seconds: steadier on a shared machine).
Then the cost of `sim.reset()` for the whole stack (physics, every node's reset hook, the scheduler), averaged over
--resets calls made after a little driving, for 1 and 4 cars in `empty`.

Uses only APIs present before issue 25 (Simulator, Car, Spawn, attach_driver, starting_row, ConstantCommand,
load_world), so `PYTHONPATH=/path/to/old/src python bench/bench_fleet.py` gives the before figures from the same
script (`racecar-sim bench --speed --compare OLD/src` runs it both ways).
"""

from __future__ import annotations

import argparse
import math
import re
import resource
import shutil
import statistics
import subprocess
import sys
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
from racecar_sim.drivers import ConstantCommand
from racecar_sim.runtime.driving import attach_driver
from racecar_sim.worlds import load_world
from racecar_sim.worlds.row import starting_row

GAP = 4.0  # m between neighbours in `empty`: more than the 3.2 m circles they drive
WARM_UP = 0.5  # sim s run before the timing starts
TRACK_STRAIGHT, TRACK_RADIUS, TRACK_HALF_WIDTH = 30.0, 6.0, 1.2  # m: the oval's straights, bends, half its width

Make = Callable[[], Simulator]


def oval_track(path: Path, straight: float = TRACK_STRAIGHT, radius: float = TRACK_RADIUS) -> Path:
    """Write an oval race-track CSV (x, y, w_right, w_left; the F1TENTH format) at `path`: two straights joined by
    half circles, counter-clockwise, a point every 0.5 m; the first point mid-way along the lower straight."""
    step = 0.5
    points = []
    for x in np.arange(0.0, straight / 2, step):  # the lower straight, from its middle
        points.append((x, -radius))
    for a in np.arange(-math.pi / 2, math.pi / 2, step / radius):  # the right bend
        points.append((straight / 2 + radius * math.cos(a), radius * math.sin(a)))
    for x in np.arange(straight / 2, -straight / 2, -step):  # the upper straight
        points.append((x, radius))
    for a in np.arange(math.pi / 2, 3 * math.pi / 2, step / radius):  # the left bend
        points.append((-straight / 2 + radius * math.cos(a), radius * math.sin(a)))
    for x in np.arange(-straight / 2, 0.0, step):  # back to the start
        points.append((x, -radius))
    lines = ["# x_m,y_m,w_tr_right_m,w_tr_left_m"]
    lines += [f"{x:.4f},{y:.4f},{TRACK_HALF_WIDTH},{TRACK_HALF_WIDTH}" for x, y in points]
    path.write_text("\n".join(lines) + "\n")
    return path


def listened(sim: Simulator) -> Simulator:
    """Every car's /scan listened to (as a recording or a driver does)."""
    for car in sim.cars:
        sim.subscribe(car.lidar.topic, lambda msg: None)
    return sim


def empty_fleet(count: int) -> Simulator:
    """`count` cars side by side along y in `empty`, each driving its circle."""
    cars = [Car(f"car{k + 1}", spawn=Spawn(0.0, k * GAP, 0.05, 0.0), camera=False) for k in range(count)]
    sim = Simulator(world="empty", cars=cars)
    for car in sim.cars:
        ConstantCommand(sim.bus, sim.scheduler, 1.0, 0.2, topic=car.topic(NAVIGATION))
    return listened(sim)


def row_fleet(world: str, count: int, driver: str) -> Simulator:
    """`count` cars in a row in `world` as `racecar-sim run --cars` places them, each with its own `driver`."""
    spawns = starting_row(load_world(world), count)
    sim = Simulator(world=world, cars=[Car(f"car{k + 1}", spawn=s, camera=False) for k, s in enumerate(spawns)])
    for car in sim.cars:
        attach_driver(sim, car, driver, {})
    return listened(sim)


CLI_DRIVERS = {"empty": ("constant", {"speed": 1.0}), "tunnel": ("wall-follow", {}), "track": ("pure-pursuit", {})}
"""Each CLI world's driver and its options: a constant 1 m/s in empty, each car following its wall in the tunnel, and
pure pursuit of the centerline on the generated oval track."""


def cli_row(count: int, world: str = "empty") -> Simulator:
    """The fleet of `racecar-sim run --world WORLD --cars N` with CLI_DRIVERS' driver (in empty: `--driver constant
    --speed 1`), built in-process: the CLI's row (CAR_SPACING apart along the spawn heading, or back along a track's
    centerline), each car its own driver, every scan listened to (the run's log listens, as here). `world`: empty,
    tunnel or a track CSV's path."""
    driver, options = CLI_DRIVERS[world if world in CLI_DRIVERS else "track"]
    spawns = starting_row(load_world(world), count)
    sim = Simulator(world=world, cars=[Car(f"car{k + 1}", spawn=s, camera=False) for k, s in enumerate(spawns)])
    for car in sim.cars:
        attach_driver(sim, car, driver, options)
    return listened(sim)


def cli_args(world: str) -> list[str]:
    """`racecar-sim run` for `world` (empty, tunnel or a track CSV) with its CLI_DRIVERS' driver, camera and video
    off."""
    driver, options = CLI_DRIVERS[world if world in CLI_DRIVERS else "track"]
    args = ["run", "--world", world, "--driver", driver, "--no-camera", "--no-video"]
    return args + [item for name, value in options.items() for item in (f"--{name}", f"{value:g}")]


def cli_seconds(count: int, duration: float, record: bool, folder: Path, world: str = "empty") -> tuple[float, float]:
    """Wall seconds of `racecar-sim run` with `count` cars for `duration` sim s in `world`, a fresh process from start
    to exit, and those of its run loop alone (the sim time over the real-time factor it prints)."""
    out = folder / "cli-run"
    shutil.rmtree(out, ignore_errors=True)
    args = [*cli_args(world), "--cars", str(count), "--duration", f"{duration:g}", "--no-summary", "--out", str(out)]
    if not record:
        args.append("--no-record")
    code = "import sys; from racecar_sim.cli.main import main; sys.argv[0] = 'racecar-sim'; sys.exit(main())"
    start = time.perf_counter()
    result = subprocess.run([sys.executable, "-c", code, *args], capture_output=True, text=True, check=False)
    wall = time.perf_counter() - start
    if result.returncode != 0:
        raise RuntimeError(f"racecar-sim {' '.join(args)} failed: {result.stderr.strip()[-2000:]}")
    printed = re.search(r"real-time factor\s+([0-9.]+)x", result.stdout)
    if printed is None:
        raise RuntimeError(f"racecar-sim {' '.join(args)} printed no real-time factor:\n{result.stdout}")
    return wall, duration / float(printed.group(1))


BARE_PROCESS = """
import sys
import mujoco
import numpy as np

mujoco.MjModel.from_xml_path(sys.argv[1])
model = mujoco.MjModel.from_binary_path(sys.argv[3])
data = mujoco.MjData(model)
replay = np.load(sys.argv[2])
mujoco.mj_forward(model, data)
for nstep, ctrl in zip(replay["steps"].tolist(), replay["ctrl"]):
    data.ctrl[:] = ctrl
    mujoco.mj_step(model, data, nstep=nstep)
"""
"""Bare MuJoCo as a whole process, as a user without racecar-sim runs it: import mujoco, compile the model's XML
(argv[1]), set the wheel commands of the replay (argv[2], .npz: steps and ctrl per chunk) and step. The XML's
numbers are MuJoCo's printed ones, rounded, and in a fleet that crashes (8 cars in the tunnel) the rounded model runs
another, slower course; so the process compiles the XML for its cost and steps the very model compiled in-process
(argv[3], mj_saveModel's), whose course is the replay's."""


def bare_process_files(sim: Simulator, controls: list[tuple[int, np.ndarray]], folder: Path) -> tuple[Path, Path, Path]:
    """The XML of `sim`'s model (MjSpec.to_xml), the replay's controls and the compiled model itself (.mjb), for
    BARE_PROCESS."""
    xml, replay, binary = folder / "bare-model.xml", folder / "bare-replay.npz", folder / "bare-model.mjb"
    xml.write_text(sim.spec.to_xml())
    steps = np.array([n for n, _ in controls], np.int64)
    ctrl = np.array([c for _, c in controls], np.float64).reshape(len(controls), -1)
    np.savez(replay, steps=steps, ctrl=ctrl)
    mujoco.mj_saveModel(sim.model, str(binary), None)
    return xml, replay, binary


def children_cpu() -> float:
    """CPU seconds (user and system) of this process's finished children: steadier than wall time on a shared
    machine, where other processes take turns on the cores."""
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def bare_process_seconds(xml: Path, replay: Path, binary: Path) -> float:
    """Wall seconds of BARE_PROCESS from start to exit: the interpreter's start, importing mujoco, compiling the
    model and stepping it under the replay's controls."""
    start = time.perf_counter()
    result = subprocess.run(
        [sys.executable, "-c", BARE_PROCESS, str(xml), str(replay), str(binary)],
        capture_output=True,
        text=True,
        check=False,
    )
    wall = time.perf_counter() - start
    if result.returncode != 0:
        raise RuntimeError(f"bare MuJoCo's process failed: {result.stderr.strip()[-2000:]}")
    return wall


def measure_cli(
    count: int, duration: float, rounds: int, record: bool, folder: Path, world: str = "empty"
) -> dict[str, float]:
    """The CLI's real-time factor (start-up included), bare MuJoCo's on its model in process, the median per-round
    ratio, that of the run loop alone (start-up, the one-time costs before the loop and the exit left out), the
    seconds outside the loop, and bare MuJoCo as a whole process (its start, import and compile included) with the
    CLI's ratio to that."""
    controls = recorded_controls(lambda: cli_row(count, world), duration)
    sim = cli_row(count, world)
    model = sim.model
    xml, replay, binary = bare_process_files(sim, controls, folder)
    sim.close()
    cli, bare, ratio, loop, outside, process, process_ratio, cpu_ratio = [], [], [], [], [], [], [], []
    for _ in range(rounds):
        cpu = children_cpu()
        wall, loop_wall = cli_seconds(count, duration, record, folder, world)
        cli_cpu, cpu = children_cpu() - cpu, children_cpu()
        bare_wall = bare_seconds(model, controls, 0)
        process_wall = bare_process_seconds(xml, replay, binary)
        cpu_ratio.append((children_cpu() - cpu) / cli_cpu)
        cli.append(duration / wall)
        bare.append(duration / bare_wall)
        ratio.append(bare_wall / wall)
        loop.append(bare_wall / loop_wall)
        outside.append(wall - loop_wall)
        process.append(process_wall)
        process_ratio.append(process_wall / wall)
    return {
        "rtf": statistics.median(cli),
        "bare": statistics.median(bare),
        "ratio": statistics.median(ratio),
        "loop": statistics.median(loop),
        "outside": statistics.median(outside),
        "process": statistics.median(process),
        "process_ratio": statistics.median(process_ratio),
        "cpu_ratio": statistics.median(cpu_ratio),
    }


def recorded_controls(make: Make, duration: float) -> list[tuple[int, np.ndarray]]:
    """The (steps, actuator controls) of every mj_step call of one pipeline run of `duration` sim seconds."""
    controls: list[tuple[int, np.ndarray]] = []
    step = mujoco.mj_step

    def recorded(model: mujoco.MjModel, data: mujoco.MjData, nstep: int = 1) -> None:
        controls.append((nstep, data.ctrl.copy()))
        step(model, data, nstep=nstep)

    sim = make()
    mujoco.mj_step = recorded
    try:
        sim.run_until(duration)
    finally:
        mujoco.mj_step = step
    sim.close()
    return controls


def pipeline_seconds(make: Make, duration: float) -> tuple[float, int, int, mujoco.MjModel]:
    """Wall seconds of `duration` sim seconds of a freshly built pipeline after WARM_UP sim seconds (building and the
    first scans' one-time costs excluded: loading the compiled kernels, slicing the world), the steps before and
    after the timing started, and its model."""
    sim = make()
    sim.run_until(WARM_UP)
    warm_steps = sim.time_ns // sim.step_ns
    start = time.perf_counter()
    sim.run_until(WARM_UP + duration)
    wall = time.perf_counter() - start
    steps, model = sim.time_ns // sim.step_ns, sim.model
    sim.close()
    return wall, warm_steps, steps, model


def bare_seconds(model: mujoco.MjModel, controls: list[tuple[int, np.ndarray]], warm_steps: int) -> float:
    """Wall seconds of bare mj_step replaying a pipeline run: the same steps in the same chunks under the same
    controls, no Python in between; the first `warm_steps` not timed."""
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    step = mujoco.mj_step
    done, k = 0, 0
    while done < warm_steps:
        nstep, ctrl = controls[k]
        data.ctrl[:] = ctrl
        step(model, data, nstep=nstep)
        done, k = done + nstep, k + 1
    if done != warm_steps:
        raise RuntimeError(f"the replay's chunks do not end at the warm-up's {warm_steps} steps")
    start = time.perf_counter()
    for nstep, ctrl in controls[k:]:
        data.ctrl[:] = ctrl
        step(model, data, nstep=nstep)
    return time.perf_counter() - start


def measure(make: Make, duration: float, rounds: int) -> dict[str, float]:
    """Median pipeline and bare real-time factors and the median per-round ratio, over interleaved rounds."""
    controls = recorded_controls(make, WARM_UP + duration)
    pipe, bare, ratio = [], [], []
    for _ in range(rounds):
        wall, warm_steps, steps, model = pipeline_seconds(make, duration)
        if steps != sum(n for n, _ in controls):
            raise RuntimeError(f"the pipeline stepped {steps} times, the replay {sum(n for n, _ in controls)}")
        bare_wall = bare_seconds(model, controls, warm_steps)
        pipe.append(duration / wall)
        bare.append(duration / bare_wall)
        ratio.append(bare_wall / wall)
    return {"rtf": statistics.median(pipe), "bare": statistics.median(bare), "ratio": statistics.median(ratio)}


def reset_cost(count: int, resets: int) -> float:
    """Mean wall seconds of one sim.reset() of `count` cars in `empty`, each after 0.1 s of driving (not timed)."""
    sim = empty_fleet(count)
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
    p.add_argument("--cars", type=int, nargs="+", default=[1, 2, 4, 8], help="fleet sizes (default 1 2 4 8)")
    p.add_argument("--worlds", nargs="*", default=["empty", "tunnel"], choices=("empty", "tunnel"))
    p.add_argument("--track-cars", type=int, default=30, help="cars on the generated oval track (0: none; default 30)")
    p.add_argument("--duration", type=float, default=10.0, help="sim seconds per run (default 10)")
    p.add_argument("--rounds", type=int, default=3, help="interleaved pipeline/bare rounds (default 3)")
    p.add_argument("--resets", type=int, default=500, help="reset() calls averaged (default 500)")
    p.add_argument("--reset-cars", type=int, nargs="*", default=[1, 4], help="fleet sizes for the reset cost")
    p.add_argument(
        "--cli-cars", type=int, nargs="*", default=[1, 4, 8], help="fleet sizes run by the CLI (default 1 4 8)"
    )
    p.add_argument("--cli-duration", type=float, default=60.0, help="sim seconds of each CLI run (default 60)")
    p.add_argument(
        "--cli-worlds",
        nargs="*",
        default=["empty"],
        choices=("empty", "tunnel", "track"),
        help="worlds of the CLI runs (default empty; track: the generated oval)",
    )
    p.add_argument(
        "--cli-recording",
        choices=("off", "on", "both"),
        default="both",
        help="the CLI runs with --no-record (off), recording (on) or both (default)",
    )
    p.add_argument(
        "--cli-track-cars",
        type=int,
        default=30,
        help="a fleet size run by the CLI on the track besides --cli-cars (default 30; 0: none)",
    )
    p.add_argument("--quick", action="store_true", help="1 and 2 cars, 4 on the track, 1 s, 1 round: a check it runs")
    args = p.parse_args()
    print(machine_line(), flush=True)  # absolute figures belong to a machine
    if args.quick:
        args.cars, args.track_cars, args.duration, args.rounds, args.resets = [1, 2], 4, 1.0, 1, 20
        args.cli_cars, args.cli_duration, args.cli_track_cars = [2], 1.0, 0
    print(
        f"racecar_sim from {Path(racecar_sim.__file__).parent}; lidar on, camera off, every /scan listened to; "
        f"{args.duration:g} sim s, median of {args.rounds} interleaved rounds against bare mj_step of the same model"
    )
    print(f"{'world':<8}{'cars':>5}{'real-time factor':>18}{'bare MuJoCo':>13}{'ratio':>7}{'car-s per wall s':>18}")
    with tempfile.TemporaryDirectory() as folder:
        cases: list[tuple[str, int, Make]] = []
        for world in args.worlds:
            for count in args.cars:
                if world == "empty":
                    cases.append((world, count, lambda n=count: empty_fleet(n)))
                else:
                    cases.append((world, count, lambda n=count, w=world: row_fleet(w, n, "wall-follow")))
        if args.track_cars:
            track = str(oval_track(Path(folder) / "oval.csv"))
            cases.append(("track", args.track_cars, lambda: row_fleet(track, args.track_cars, "pure-pursuit")))
        for world, count, make in cases:
            r = measure(make, args.duration, args.rounds)
            print(
                f"{world:<8}{count:>5}{r['rtf']:>17.1f}x{r['bare']:>12.1f}x{r['ratio']:>7.2f}{r['rtf'] * count:>18.1f}",
                flush=True,
            )
        if args.cli_cars or args.cli_track_cars:
            print(
                f"racecar-sim run --world empty --cars N --driver constant --speed 1 --no-camera --no-video "
                f"--no-summary --duration {args.cli_duration:g} (tunnel: --driver wall-follow; track: the oval, "
                f"--driver pure-pursuit): a fresh process, start to exit, against bare mj_step replaying its controls "
                f"from the start; the loop ratio leaves out what is outside the run loop; median of {args.rounds} "
                f"interleaved rounds"
            )
            print(
                f"{'world':<8}{'recording':>10}{'cars':>5}{'real-time factor':>18}{'bare MuJoCo':>13}{'ratio':>7}"
                f"{'loop ratio':>12}{'outside loop':>14}{'bare process':>14}{'process ratio':>15}{'CPU ratio':>11}"
            )
            for world in args.cli_worlds:
                where = str(oval_track(Path(folder) / "cli-oval.csv")) if world == "track" else world
                counts = args.cli_cars + ([args.cli_track_cars] if world == "track" and args.cli_track_cars else [])
                for record in [r == "on" for r in ("off", "on") if args.cli_recording in (r, "both")]:
                    for count in counts:
                        r = measure_cli(count, args.cli_duration, args.rounds, record, Path(folder), where)
                        print(
                            f"{world:<8}{'on' if record else 'off':>10}{count:>5}{r['rtf']:>17.1f}x"
                            f"{r['bare']:>12.1f}x{r['ratio']:>7.2f}{r['loop']:>12.2f}{r['outside']:>12.2f} s"
                            f"{r['process']:>12.2f} s{r['process_ratio']:>15.2f}{r['cpu_ratio']:>11.2f}",
                            flush=True,
                        )
    print(f"sim.reset() in empty, lidar on, camera off, mean of {args.resets} calls")
    for count in args.reset_cars:
        cost = reset_cost(count, args.resets)
        print(f"{count:>4} car{'s' if count > 1 else ' '}  {cost * 1e6:8.0f} µs")


if __name__ == "__main__":
    main()
