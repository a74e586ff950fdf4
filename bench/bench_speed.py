"""The speed figures in one run: `python bench/bench_speed.py [--quick] [--compare SRC]`
(or `racecar-sim bench --speed`).

Runs, one after the other, the benches behind each figure and prints their tables, each a ratio measured within
its own run (interleaved rounds, medians):
  1. the main job (camera, recording, video)     bench_mainjob.py   real-time factor, and against the bare job
  2. the lidar pipeline (camera off)             bench_pipeline.py  against bare MuJoCo stepping, tunnel and walker
  3. start-up                                    bench_startup.py   short runs against the numpy + mujoco floor
  4. real maps                                   bench_maps.py      a basement-like map against the empty world
  5. scaling                                     bench_scaling.py   against beams, static geoms and cars
  6. fleets (1-8 cars, 30 on a track)            bench_fleet.py     against bare MuJoCo stepping the same N-car model
--compare SRC measures the code in SRC too (PYTHONPATH=SRC: an older checkout's src), for before/after figures
from the same run. --quick: shorter runs (a check that everything runs, not figures to quote).
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
from pathlib import Path

from racecar_sim.core.machine import machine_line

HERE = Path(__file__).resolve().parent


def sections(quick: bool) -> list[tuple[str, str, list[str], bool]]:
    """(title, script, arguments, whether the script compares trees itself via --compare)."""
    d, r = ("2", "1") if quick else ("20", "3")
    short, rounds = ("2", "1") if quick else ("5", "3")
    return [
        ("1. main job: camera, recording, video", "bench_mainjob.py", ["--duration", d, "--rounds", r], True),
        ("2. lidar pipeline against bare MuJoCo", "bench_pipeline.py", ["--duration", d, "--rounds", r], False),
        ("3. start-up", "bench_startup.py", ["--quick"] if quick else ["--repeats", "7"], True),
        ("4. real maps against the empty world", "bench_maps.py", ["--duration", short, "--rounds", rounds], False),
        ("5. scaling: beams, static geoms, cars", "bench_scaling.py", ["--duration", short, "--rounds", rounds], False),
        (
            "6. fleets against bare MuJoCo",
            "bench_fleet.py",
            ["--quick"] if quick else ["--duration", short, "--rounds", rounds, "--reset-cars"],
            False,
        ),
    ]


def compare_problem(compare: str, own_src: Path) -> str | None:
    """Why `compare` is not another checkout's src folder (None if it is): a path that holds no racecar_sim would
    measure this checkout twice, as if it were the old one."""
    folder = Path(compare)
    if not (folder / "racecar_sim" / "__init__.py").is_file():
        why = "no such folder" if not folder.exists() else "not a src folder: it holds no racecar_sim/__init__.py"
        return (
            f"{why} (give an older checkout's src folder, e.g. git worktree add /tmp/old HEAD~1, then "
            "--compare /tmp/old/src)"
        )
    if folder.resolve() == own_src.resolve():
        return "is this checkout's own src folder: give an older checkout's"
    return None


def run(script: str, args: list[str], pythonpath: str | None = None) -> int:
    env = dict(os.environ)
    if pythonpath is not None:
        env["PYTHONPATH"] = pythonpath
    sys.stdout.flush()
    return subprocess.run([sys.executable, str(HERE / script), *args], env=env, check=False).returncode


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=" ".join(__doc__.split("\n\n")[0].split()))
    parser.add_argument("--quick", action="store_true", help="short runs: checks that every bench runs")
    parser.add_argument("--compare", metavar="SRC", help="also measure the code in SRC (e.g. an older checkout's src)")
    args = parser.parse_args(argv)
    failed = []
    src = str(HERE.parent / "src")
    if args.compare is not None:
        problem = compare_problem(args.compare, Path(src))
        if problem:
            parser.exit(2, f"{parser.prog}: error: --compare {args.compare}: {problem}\n")
    print(machine_line(), flush=True)  # absolute figures belong to a machine: the ratios travel, the rates do not
    for title, script, extra, compares in sections(args.quick):
        print(f"\n=== {title} ({script}) ===", flush=True)
        if args.compare and compares:
            extra = extra + (
                ["--compare", args.compare] if script != "bench_startup.py" else ["--compare", src, args.compare]
            )
        code = run(script, extra)
        if args.compare and not compares and code == 0:
            print(f"--- the same, PYTHONPATH={args.compare} ---", flush=True)
            code = run(script, extra, args.compare)
        if code:
            failed.append(script)
    if failed:
        print(f"\nfailed: {', '.join(failed)}", file=sys.stderr)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
