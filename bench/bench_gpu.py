"""The GPU batch: `python bench/bench_gpu.py [--device warp|warp-cpu] [--worlds 1 256 ...] [--lidar-on host|device]
[--vehicle seed|f1tenth|FILE]`.

Car-steps per second (control steps x worlds per wall second, 20 Hz control, lidar on, random-walk actions, after a
warm-up that compiles Warp's kernels and captures the CUDA graphs) of `DriveBatch(n, device=...)` (MuJoCo Warp)
against the CPU batch (`device="cpu"`, a thread per core) at the same n, and a trajectory check: from the same
seeds and actions, the device batch's car bases against the CPU batch's over --check-steps control steps, with the
tolerances of tests/test_envs_batch_warp.py::test_drive_batch_on_warp_matches_the_cpu_batch (1e-4 m on the base
position, 1e-4 m/s on the speed, the same terminated/truncated flags). --vehicle times a vehicle set (default seed);
with a tyre set the tyres and rate limits run as Warp kernels (physics/tyre_warp.py) and the check takes the
tolerances of test_drive_batch_on_warp_with_tyres_matches_the_cpu_batch (5e-4 m, 5e-3 m/s).

The CPU batch is measured up to --cpu-max worlds (default 1024): for larger n its column is its rate at --cpu-max
worlds (the CPU batch's car-steps/s are flat once every core is busy), marked so, and the trajectory check covers
the first --cpu-max worlds (world i has seed i on both sides, whatever n).

Where the lidar runs: on the Warp devices only the physics and the crash check's contacts run on the device. After
each control step the batch copies every world's qpos back to the host, and the scan is BatchLidar's, as on the CPU
batch: the compiled 2-D wall cast (numba), the 3-D RayCaster where that cannot answer, and the noise, chunk by chunk
on the batch's host threads (`threads`, default every core). With --lidar-on device (DriveBatch(lidar_on="device"))
the scan is cast on the device instead (MuJoCo Warp's batched rays, envs/batch_warp.py WarpLidar) and only the
distances come back for the noise on the host. The "host lidar" ("dev. lidar") column is the share of the device
batch's step spent in the scans (host: the casts and noise; device: the device cast, the copy back and the noise).

--device warp needs a CUDA GPU and the [gpu] extra (mujoco-warp, warp-lang); warp-cpu runs MuJoCo Warp on Warp's
CPU device (slow: a check that it runs, not a GPU figure). --quick: warp-cpu, 1 and 8 worlds, a few steps.
Without mujoco-warp, or --device warp without a CUDA GPU: one line saying what is missing, exit 2.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from collections.abc import Callable
from typing import Any

import numpy as np

from racecar_sim.core.errors import RacecarSimError
from racecar_sim.envs.batch import DriveBatch

SEED = 0
POS_TOL = SPEED_TOL = 1e-4  # tests/test_envs_batch_warp.py::test_drive_batch_on_warp_matches_the_cpu_batch
TYRE_POS_TOL, TYRE_SPEED_TOL = 5e-4, 5e-3  # ... ::test_drive_batch_on_warp_with_tyres_matches_the_cpu_batch


class Walk:
    """Random-walk actions per world (as the Warp test's: a policy's actions change smoothly; actions drawn afresh
    each step make the wheels slip chaotically, where float32 and float64 part within a few steps)."""

    def __init__(self, worlds: int, seed: int = 10) -> None:
        self.rng, self.actions = np.random.default_rng(seed), np.zeros((worlds, 2))

    def __call__(self) -> np.ndarray:
        self.actions = np.clip(self.actions + self.rng.normal(0, 0.1, self.actions.shape), -1, 1)
        return self.actions


def timed_lidar(batch: DriveBatch) -> list[float]:
    """Wrap the batch's lidar so that the seconds spent in its scans add up in the returned one-item list (host:
    BatchLidar.scans; device: WarpLidar.ranges and the noise, BatchLidar.publish)."""
    spent = [0.0]
    lidar = batch.lidar
    if lidar is None:
        return spent
    targets: list[tuple[Any, str]] = [(lidar, "scans")]
    if batch.warp_lidar is not None:
        targets = [(batch.warp_lidar, "ranges"), (lidar, "publish")]
    for owner, name in targets:
        method: Callable[..., np.ndarray] = getattr(owner, name)

        def wrapped(*args: Any, method: Callable[..., np.ndarray] = method) -> np.ndarray:
            start = time.perf_counter()
            try:
                return method(*args)
            finally:
                spent[0] += time.perf_counter() - start

        setattr(owner, name, wrapped)  # an instance attribute over the method
    return spent


def rate(batch: DriveBatch, warmup: int, steps: int) -> tuple[float, float]:
    """(car-steps/s, share of the timed steps spent in the lidar) over `steps` control steps after `warmup`."""
    walk = Walk(batch.num_envs)
    batch.reset(seed=SEED)
    for _ in range(warmup):
        batch.step(walk())
    spent = timed_lidar(batch)
    start = time.perf_counter()
    for _ in range(steps):
        batch.step(walk())
    wall = time.perf_counter() - start
    return steps * batch.num_envs / wall, spent[0] / wall


def tolerances(batch: DriveBatch) -> tuple[float, float]:
    """The trajectory check's (m, m/s): the tyre test's for a model with tyres, the seed test's otherwise."""
    warp = batch.warp
    return (TYRE_POS_TOL, TYRE_SPEED_TOL) if warp is not None and warp.tyres is not None else (POS_TOL, SPEED_TOL)


def trajectory(device: DriveBatch, cpu: DriveBatch, steps: int) -> tuple[float, float, float, int, int]:
    """Both batches from the same seeds, `steps` control steps of the same actions (the device batch's first
    cpu.num_envs worlds against the CPU batch): (max |d base position| m, its median over the worlds, max |d speed|
    m/s, flag mismatches, worlds out of tolerance at some step)."""
    m = cpu.num_envs
    walk = Walk(device.num_envs)
    device.reset(seed=SEED)
    cpu.reset(seed=SEED)
    root = slice(cpu.root_qpos, cpu.root_qpos + 3)
    dv = 0.0
    flags = 0
    bad = np.zeros(m, bool)
    per_world = np.zeros(m)
    pos_tol, speed_tol = tolerances(device)
    for _ in range(steps):
        actions = walk()
        _, _, terminated, truncated, _ = device.step(actions)
        _, _, cpu_terminated, cpu_truncated, _ = cpu.step(actions[:m])
        wrong = (terminated[:m] != cpu_terminated) | (truncated[:m] != cpu_truncated)
        pos = np.abs(device.qpos[:m, root] - cpu.qpos[:, root]).max(axis=1)
        speed = np.abs(device.speed[:m] - cpu.speed)
        per_world = np.maximum(per_world, pos)
        dv, flags = max(dv, float(speed.max())), flags + int(wrong.sum())
        bad |= wrong | (pos > pos_tol) | (speed > speed_tol)
    return float(per_world.max()), float(np.median(per_world)), dv, flags, int(bad.sum())


def quiet_warp_init() -> None:
    """Initialise Warp before DriveBatch does, with its native "could not find the CUDA driver" warning (printed on
    stderr at initialisation on a machine without a GPU) silenced, so that a missing GPU is the one line of
    DriveBatch's ConfigError. Nothing when Warp is not installed (DriveBatch says that)."""
    try:
        import warp
    except ImportError:
        return
    warp.config.log_level = warp.LOG_WARNING
    sys.stderr.flush()
    saved = os.dup(2)
    try:
        with open(os.devnull, "w") as null:
            os.dup2(null.fileno(), 2)
            warp.init()
    finally:
        os.dup2(saved, 2)
        os.close(saved)


def main(argv: list[str] | None = None) -> int:
    """Measure and print the table; 2 with one line on stderr when MuJoCo Warp or the device is missing."""
    parser = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    parser.add_argument("--device", choices=("warp", "warp-cpu"), default="warp")
    parser.add_argument("--worlds", type=int, nargs="+", default=[1, 256, 4096, 16384])
    parser.add_argument("--steps", type=int, default=50, help="timed control steps per measurement (default 50)")
    parser.add_argument("--warmup", type=int, default=5, help="control steps before timing (default 5)")
    parser.add_argument("--cpu-max", type=int, default=1024, help="largest CPU batch measured (default 1024)")
    parser.add_argument("--world", default="walker", help="the world timed (default walker, Drive-v0's)")
    parser.add_argument(
        "--check-world", default="empty", help="the trajectory check's world (default empty, the Warp test's)"
    )
    parser.add_argument("--check-steps", type=int, default=20, help="control steps of the trajectory check")
    parser.add_argument(
        "--lidar-on", choices=("host", "device"), default="host", help="where the device batch casts its lidar"
    )
    parser.add_argument("--vehicle", default="seed", help="the vehicle set: seed (default), f1tenth or a YAML file")
    parser.add_argument("--quick", action="store_true", help="warp-cpu, 1 and 8 worlds, a few steps (a check)")
    args = parser.parse_args(argv)
    if args.quick:
        args.device, args.worlds, args.steps, args.warmup, args.check_steps = "warp-cpu", [1, 8], 3, 1, 5
    if min(args.worlds) < 1 or min(args.steps, args.warmup + 1, args.check_steps, args.cpu_max) < 1:
        parser.error("--worlds, --steps, --check-steps and --cpu-max must be >= 1, --warmup >= 0")
    quiet_warp_init()
    cpu_batches: dict[tuple[str, int], DriveBatch] = {}
    cpu_rates: dict[int, float] = {}

    def cpu_batch(world: str, m: int) -> DriveBatch:
        if (world, m) not in cpu_batches:
            cpu_batches[world, m] = DriveBatch(m, world=world, device="cpu", vehicle=args.vehicle)
        return cpu_batches[world, m]

    try:
        for k, n in enumerate(args.worlds):
            # ConfigError first: no Warp / no GPU
            device = DriveBatch(n, world=args.world, device=args.device, lidar_on=args.lidar_on, vehicle=args.vehicle)
            if k == 0:
                header(device, args)
            got, lidar_share = rate(device, args.warmup, args.steps)
            m = min(n, args.cpu_max)
            if m not in cpu_rates:
                cpu_rates[m] = rate(cpu_batch(args.world, m), args.warmup, args.steps)[0]
            if args.check_world != args.world:
                device.close()
                device = DriveBatch(
                    n, world=args.check_world, device=args.device, lidar_on=args.lidar_on, vehicle=args.vehicle
                )
            dq, median, dv, flags, bad = trajectory(device, cpu_batch(args.check_world, m), args.check_steps)
            device.close()
            ok = "yes" if bad == 0 else f"NO: {bad} of {m} worlds" + (f", {flags} flag mismatches" if flags else "")
            cpu = f"{cpu_rates[m]:,.0f}" + ("*" if m < n else " ")
            print(
                f"{n:>7}  {got:>18,.0f}  {cpu:>16}  {got / cpu_rates[m]:>7.2f}  {lidar_share:>10.0%}  {m:>7}  "
                f"{dq:>10.1e}  {median:>10.1e}  {dv:>9.1e}  {ok}",
                flush=True,
            )
    except RacecarSimError as error:
        print(f"bench_gpu.py: error: {error}", file=sys.stderr)
        return 2
    finally:
        for batch in cpu_batches.values():
            batch.close()
    return 0


def header(device: DriveBatch, args: argparse.Namespace) -> None:
    """The device, where the lidar runs, what the CPU column is, and the table's header."""
    assert device.warp is not None
    dev = device.warp.device
    pos_tol, speed_tol = tolerances(device)
    beams = device.lidar.spec.samples if device.lidar is not None else 0
    print(
        f"device {dev.alias} ({dev.name}), Warp {_warp_version()}; world {args.world}, vehicle {args.vehicle}, "
        "20 Hz control"
    )
    lidar = "host lidar" if device.warp_lidar is None else "dev. lidar"
    if device.warp_lidar is not None:
        print(
            f"lidar on ({beams} beams), --lidar-on device: cast on the DEVICE (mujoco_warp.rays after kinematics), "
            "the (N, beams) distances copied back each control step, noise on the host"
        )
    else:
        print(
            f"lidar on ({beams} beams), --lidar-on host: computed on the HOST: physics and contacts on the device, "
            f"qpos copied back each control step, BatchLidar's 2-D wall cast + noise in chunks on {device.threads} "
            "host threads"
        )
    print(
        f"CPU batch: {os.cpu_count()} threads, measured up to {args.cpu_max} worlds (* = its rate at {args.cpu_max} "
        f"worlds); {args.steps} timed steps after {args.warmup} warm-up; trajectory check in {args.check_world}: "
        f"{args.check_steps} steps, tolerance {pos_tol:g} m / {speed_tol:g} m/s (the Warp test's)"
    )
    print(
        f"{'worlds':>7}  {'device car-steps/s':>18}  {'CPU car-steps/s':>16}  {'ratio':>7}  {lidar:>10}  "
        f"{'checked':>7}  {'max |dq| m':>10}  {'median |dq|':>10}  {'max |dv|':>9}  within tolerance",
        flush=True,
    )


def _warp_version() -> str:
    import warp

    return str(warp.__version__)


if __name__ == "__main__":
    sys.exit(main())
