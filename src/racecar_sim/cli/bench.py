"""`racecar-sim bench`: real-time factor of the full pipeline, against bare MuJoCo stepping of the same model.

Figures are ratios from one run on this machine: sim seconds per wall second (real-time factor) and the
share of wall time that MuJoCo itself takes.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import time
from pathlib import Path

import mujoco

from racecar_sim.cli.args import positive_float, positive_int
from racecar_sim.core.errors import ConfigError, RacecarSimError
from racecar_sim.core.machine import machine_line
from racecar_sim.drivers import ConstantCommand
from racecar_sim.physics import preset_names
from racecar_sim.runtime import Simulator


def add_parser(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser("bench", help="real-time factor of the full pipeline: sensors off, lidar, lidar + camera")
    p.add_argument("--world", default="empty")
    p.add_argument("--physics", default="default", choices=preset_names())
    p.add_argument(
        "--duration",
        type=positive_float,
        help=f"sim seconds per measurement (default {FULL[0]:g}; {QUICK[0]:g} with --quick)",
    )
    p.add_argument(
        "--repeat",
        type=positive_int,
        help=f"measurements; the best is reported (default {FULL[1]}; {QUICK[1]} with --quick)",
    )
    p.add_argument("--no-camera", action="store_true", help="skip the lidar + camera measurement (no OpenGL)")
    p.add_argument(
        "--speed",
        action="store_true",
        help="instead: every speed figure (main job, lidar pipeline, start-up, maps, scaling, fleets) by the source "
        "checkout's bench/bench_speed.py",
    )
    p.add_argument(
        "--quick",
        action="store_true",
        help="short runs, one of each: a check that the bench runs, not figures to quote (with --speed too)",
    )
    p.add_argument(
        "--compare",
        metavar="SRC",
        help="with --speed: also measure the code in SRC, an older checkout's src folder (before/after)",
    )


FULL, QUICK = (30.0, 3), (2.0, 1)  # (sim seconds per measurement, measurements) by default and with --quick
SENSOR_TOPICS = ("/scan", "/camera/zed/rgb/image_rect_color", "/camera/zed/rgb/camera_info")


def pipeline_rtf(
    world: str, physics: str, duration: float, lidar: bool = False, camera: bool = False
) -> tuple[float, float]:
    """(real-time factor, physics share) of the full pipeline driving a 1 m/s, 0.2 rad circle.

    A subscriber listens to every sensor topic, since sensors skip their work when nobody listens.
    """
    sim = Simulator(world=world, physics=physics, lidar=lidar, camera=camera)
    if camera and sim.car.camera is None:
        raise RacecarSimError("the camera could not start (see the error above); try --no-camera")
    for topic in SENSOR_TOPICS:
        sim.subscribe(topic, lambda msg: None)
    ConstantCommand(sim.bus, sim.scheduler, 1.0, 0.2)
    physics_wall = 0.0
    step = mujoco.mj_step

    def timed_step(m: mujoco.MjModel, d: mujoco.MjData, nstep: int = 1) -> None:
        nonlocal physics_wall
        t = time.perf_counter()
        step(m, d, nstep=nstep)
        physics_wall += time.perf_counter() - t

    start = time.perf_counter()
    mujoco.mj_step = timed_step  # measure, without changing, what the simulator spends inside MuJoCo
    try:
        sim.run_until(duration)
    finally:
        mujoco.mj_step = step
    wall = time.perf_counter() - start
    sim.close()
    return duration / wall, physics_wall / wall


def bare_rtf(world: str, physics: str, duration: float) -> float:
    """Real-time factor of mj_step alone on the same model (wheels commanded, no Python per step)."""
    sim = Simulator(world=world, physics=physics, lidar=False, camera=False)
    for c in sim.car.controllers.controllers:
        sim.car.state.set_command(c.name, 20.0 if "wheel" in c.joint else 0.1)
    steps = int(duration / sim.model.opt.timestep)
    start = time.perf_counter()
    mujoco.mj_step(sim.model, sim.data, nstep=steps)
    return duration / (time.perf_counter() - start)


def check_compare(compare: str, own_src: Path) -> None:
    """ConfigError unless `compare` is the src folder of another checkout (one holding racecar_sim/__init__.py):
    a path that is not one would measure this checkout twice, as if it were the old one."""
    folder = Path(compare)
    if not (folder / "racecar_sim" / "__init__.py").is_file():
        why = "no such folder" if not folder.exists() else "not a src folder: it holds no racecar_sim/__init__.py"
        raise ConfigError(
            f"--compare {compare}: {why} (give an older checkout's src folder, e.g. "
            "git worktree add /tmp/old HEAD~1, then --compare /tmp/old/src)"
        )
    if folder.resolve() == own_src.resolve():
        raise ConfigError(f"--compare {compare}: is this checkout's own src folder: give an older checkout's")


def speed(args: argparse.Namespace) -> int:
    """Run bench/bench_speed.py of the checkout this package is installed from (pip install -e)."""
    script = Path(__file__).resolve().parents[3] / "bench" / "bench_speed.py"
    if not script.is_file():
        raise ConfigError(
            f"racecar-sim bench --speed: {script} is missing: it runs the benches of a source checkout "
            "(git clone, then pip install -e .)"
        )
    if args.compare is not None:
        check_compare(args.compare, Path(__file__).resolve().parents[2])
    extra = (["--quick"] if args.quick else []) + (["--compare", args.compare] if args.compare else [])
    return subprocess.run([sys.executable, str(script), *extra], check=False).returncode


def main(args: argparse.Namespace) -> int:
    if args.speed:
        given = [
            flag for flag, value in (("--duration", args.duration), ("--repeat", args.repeat)) if value is not None
        ]
        if given:
            raise ConfigError(
                f"{' and '.join(given)} set the real-time factor bench: --speed runs its own benches "
                "(--quick for short runs)"
            )
        return speed(args)
    if args.compare is not None:
        raise ConfigError("--compare measures an older checkout with the speed benches: give --speed too")
    defaults = QUICK if args.quick else FULL
    args.duration = defaults[0] if args.duration is None else args.duration
    args.repeat = defaults[1] if args.repeat is None else args.repeat
    quick = " (--quick: a check that it runs, not figures to quote)" if args.quick else ""
    print(machine_line())
    print(f"world {args.world}, physics preset {args.physics}, {args.duration:g} sim s, best of {args.repeat}{quick}")
    bare = max(bare_rtf(args.world, args.physics, args.duration) for _ in range(args.repeat))
    print(f"bare mj_step               real-time factor {bare:7.1f}x")
    runs = [("sensors off", False, False), ("lidar on, camera off", True, False)]
    if not args.no_camera:
        runs.append(("lidar + camera", True, True))
    for label, lidar, camera in runs:
        rtf, share = max(
            pipeline_rtf(args.world, args.physics, args.duration, lidar, camera) for _ in range(args.repeat)
        )
        print(
            f"{label:<26} real-time factor {rtf:7.1f}x  (pipeline / bare {rtf / bare:.2f}; MuJoCo stepping "
            f"{share * 100:.0f}% of wall time)"
        )
    return 0
