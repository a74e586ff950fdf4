"""The main job's speed: `racecar-sim run` (walker, wall-follow, lidar + camera, run.mcap + camera.mp4) as a user
runs it, in a subprocess, against the same job with the camera's costs switched off.

    python bench/bench_mainjob.py [--duration 20] [--rounds 3] [--compare /work/base/src]

Each round runs every job once, interleaved, and reads the real-time factor the run prints (sim time / wall time
of the stepping loop, start-up and summary excluded). Printed: the median real-time factor of each job and the
median per-round ratio to the bare job (noise, recording and video off). `--compare SRC` runs the same jobs with
PYTHONPATH=SRC too (e.g. the code before a change) in the same rounds and prints the ratios new / old. The jobs
use only options both sides have, so `PYTHONPATH=/work/base/src python bench/bench_mainjob.py` also works.
"""

from __future__ import annotations

import argparse
import os
import re
import statistics
import subprocess
import sys
import tempfile

from machine_info import machine_line

JOBS = {
    "main job (camera, noise, MCAP, video)": [],
    "no recording": ["--no-record"],
    "no video": ["--no-video"],
    "bare (no noise, no recording, no video)": ["--no-noise", "--no-record", "--no-video"],
}
BARE = "bare (no noise, no recording, no video)"
RTF = re.compile(r"real-time factor\s+([0-9.]+)x")


def run_job(extra: list[str], duration: float, pythonpath: str | None) -> float:
    """One `racecar-sim run` with `extra` options: the real-time factor it prints."""
    env = dict(os.environ)
    if pythonpath is not None:
        env["PYTHONPATH"] = pythonpath
    with tempfile.TemporaryDirectory() as out:
        cmd = [
            sys.executable,
            "-m",
            "racecar_sim",
            "run",
            "--duration",
            f"{duration:g}",
            "--out",
            out,
            "--no-summary",
            *extra,
        ]
        result = subprocess.run(cmd, check=False, capture_output=True, text=True, env=env, timeout=1800)
    if result.returncode != 0:
        raise SystemExit(f"{' '.join(cmd)} failed ({result.returncode}):\n{result.stderr[-2000:]}")
    match = RTF.search(result.stdout)
    if match is None:
        raise SystemExit(f"no real-time factor in the output of {' '.join(cmd)}:\n{result.stdout}")
    return float(match.group(1))


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--duration", type=float, default=20.0, help="sim seconds per run (default 20)")
    p.add_argument("--rounds", type=int, default=3, help="interleaved rounds; medians are printed (default 3)")
    p.add_argument("--compare", metavar="SRC", help="also run the jobs with PYTHONPATH=SRC (the code before)")
    p.add_argument("--jobs", nargs="*", choices=range(len(JOBS)), type=int, help="job indexes (default all)")
    args = p.parse_args()
    print(machine_line(), flush=True)  # absolute figures belong to a machine
    names = [n for i, n in enumerate(JOBS) if args.jobs is None or i in args.jobs or n == BARE]
    sides = {"new": os.environ.get("PYTHONPATH")} | ({"old": args.compare} if args.compare else {})
    rates: dict[tuple[str, str], list[float]] = {(s, n): [] for s in sides for n in names}
    for r in range(args.rounds):
        for name in names:
            for side, path in sides.items():
                rates[side, name].append(run_job(JOBS[name], args.duration, path))
        print(
            f"round {r + 1}/{args.rounds}: "
            + ", ".join(f"{s} {n.split(' (')[0]} {rates[s, n][-1]:.1f}x" for s in sides for n in names),
            file=sys.stderr,
        )
    print(f"racecar-sim run, walker, {args.duration:g} sim s, median of {args.rounds} rounds")
    header = f"{'job':<42}" + "".join(f"{s + ' RTF':>10}{s + ' /bare':>11}" for s in sides)
    print(header + (f"{'new/old':>9}" if "old" in sides else ""))
    for name in names:
        line = f"{name:<42}"
        for side in sides:
            ratio = statistics.median(a / b for a, b in zip(rates[side, name], rates[side, BARE]))
            line += f"{statistics.median(rates[side, name]):>9.2f}x{ratio:>11.2f}"
        if "old" in sides:
            line += f"{statistics.median(a / b for a, b in zip(rates['new', name], rates['old', name])):>9.2f}"
        print(line)


if __name__ == "__main__":
    main()
