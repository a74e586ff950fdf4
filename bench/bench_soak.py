"""Memory over a long run: `python bench/bench_soak.py [--quick] [--fleet-duration 600] [--solo-duration 3600]`.

Runs `racecar-sim run --world tunnel --no-camera` as a user runs it (the MCAP recorded, summary.png drawn), once with
`--cars 4` for --fleet-duration sim s and once with one car for --solo-duration sim s, each in a process of its own
(the CLI's main() in a child Python, so the bench can look at the run's sim time). Every --every sim s the run reads
its memory: its anonymous resident memory (RssAnon from /proc: the heap; the libraries' file pages, which the kernel
drops when memory runs short, are left out), its VmRSS, its recording writer's (its child processes'), the blocks
Python's allocator holds and the bytes malloc has handed out (glibc's mallinfo2). Printed per run: the RSS at the
end, the anonymous memory at the end of the warm-up and at the end, its least-squares slope in MB per 1000 sim s
after the warm-up and over the last half of the run (an allocator first reuses what start-up freed, so a growth
shows late), the writer's memory and slope, and the real-time factor; then the slopes of Python's blocks and of
malloc's bytes, which say where a growth is. A run whose memory stays flat shows slopes near 0.
--compare SRC runs the same jobs with PYTHONPATH=SRC too (e.g. the code before a change). --trace N: the run also
compares tracemalloc snapshots (N frames; end of the warm-up against the end of the drive) and prints the
allocations that grew most (several times slower: for finding what grows, not for figures).
"""

from __future__ import annotations

import argparse
import ctypes
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

MB = 1024 * 1024


def memory(pid: int | str = "self") -> tuple[int, int]:
    """(resident set size, its anonymous part) of a process in bytes; (0, 0) for one that has exited.

    From /proc/PID/status (VmRSS, RssAnon), or psutil where /proc has no RssAnon (then both are the RSS). The
    anonymous part is the heap and the stacks: the file pages of the libraries count in the RSS too, and the kernel
    drops those whenever memory runs short, which would read as memory given back.
    """
    fields = {}
    try:
        with open(f"/proc/{pid}/status") as f:
            for line in f:
                key, _, value = line.partition(":")
                if key in ("VmRSS", "RssAnon"):
                    fields[key] = int(value.split()[0]) * 1024
    except OSError:
        pass
    if "RssAnon" in fields:
        return fields["VmRSS"], fields["RssAnon"]
    try:
        import psutil
    except ImportError:
        return fields.get("VmRSS", 0), fields.get("VmRSS", 0)
    try:
        rss = psutil.Process(None if pid == "self" else int(pid)).memory_info().rss
    except psutil.Error:
        return 0, 0
    return rss, rss


def descendants(pid: int) -> list[int]:
    """The processes `pid` started, and theirs (Linux's /proc/PID/task/TID/children)."""
    found, todo = [], [pid]
    while todo:
        parent = todo.pop()
        try:
            tids = os.listdir(f"/proc/{parent}/task")
        except OSError:
            continue
        for tid in tids:
            try:
                with open(f"/proc/{parent}/task/{tid}/children") as f:
                    kids = [int(k) for k in f.read().split()]
            except OSError:
                continue
            found += kids
            todo += kids
    return found


class _Mallinfo2(ctypes.Structure):
    _fields_ = [
        (name, ctypes.c_size_t)
        for name in (
            "arena",
            "ordblks",
            "smblks",
            "hblks",
            "hblkhd",
            "usmblks",
            "fsmblks",
            "uordblks",
            "fordblks",
            "keepcost",
        )
    ]


def malloc_in_use() -> int | None:
    """Bytes malloc has handed out and not had back (glibc's mallinfo2: arenas and mmapped blocks), or None."""
    try:
        mallinfo2 = ctypes.CDLL(None).mallinfo2
    except (OSError, AttributeError):
        return None
    mallinfo2.restype = _Mallinfo2
    info = mallinfo2()
    return info.uordblks + info.hblkhd


def slope(points: list[tuple[float, float]]) -> float:
    """Least-squares slope of y over x."""
    n = len(points)
    mx = sum(x for x, _ in points) / n
    my = sum(y for _, y in points) / n
    sxx = sum((x - mx) ** 2 for x, _ in points)
    return sum((x - mx) * (y - my) for x, y in points) / sxx if sxx > 0 else 0.0


def child(args: argparse.Namespace) -> int:
    """In the child: the CLI's run with an RSS sample every --every sim s, written as JSON lines to --samples."""
    import tracemalloc

    from racecar_sim.cli.main import main as cli_main
    from racecar_sim.runtime import simulator

    with open(args.samples, "w", buffering=1) as out:
        snapshots: list[tracemalloc.Snapshot] = []
        init = simulator.Simulator.__init__

        def sample(sim: simulator.Simulator) -> None:
            now = sim.time
            rss, anon = memory()
            writer = sum(memory(pid)[1] for pid in descendants(os.getpid()))
            out.write(
                json.dumps(
                    {
                        "t": now,
                        "wall": time.perf_counter(),
                        "rss": rss,
                        "anon": anon,
                        "writer": writer,
                        "blocks": sys.getallocatedblocks(),
                        "malloc": malloc_in_use(),
                    }
                )
                + "\n"
            )
            if args.trace and (len(snapshots) == 0 and now >= args.warmup - 1e-9 or now >= args.duration - 1e-9):
                snapshots.append(tracemalloc.take_snapshot())  # the end of the warm-up, and the end of the drive

        def traced_init(sim: simulator.Simulator, *a: object, **k: object) -> None:
            init(sim, *a, **k)
            sim.scheduler.every(1.0 / args.every, lambda _now: sample(sim), "bench_soak")
            sample(sim)

        simulator.Simulator.__init__ = traced_init
        if args.trace:
            tracemalloc.start(args.trace)
        with tempfile.TemporaryDirectory() as folder:
            argv = ["run", "--world", "tunnel", "--no-camera", "--duration", f"{args.duration:g}", "--out", folder]
            code = cli_main(argv + (["--cars", str(args.cars)] if args.cars > 1 else []))
        if len(snapshots) >= 2:
            grown = snapshots[-1].compare_to(snapshots[0], "traceback")
            print(f"tracemalloc, {args.warmup:g} s -> {args.duration:g} s: the {args.top} allocations that grew most")
            for stat in grown[: args.top]:
                print(f"{stat.size_diff / MB:+8.2f} MB {stat.count_diff:+9d} blocks")
                for line in stat.traceback.format(limit=args.trace)[-2 * args.trace :]:
                    print("    " + line)
    return code


def soak(
    cars: int,
    duration: float,
    every: float,
    warmup: float,
    pythonpath: str | None,
    trace: int = 0,
    top: int = 10,
    keep: Path | None = None,
) -> dict[str, float]:
    """One run in a child process: its RSS samples reduced to the table's figures."""
    env = dict(os.environ)
    if pythonpath is not None:
        env["PYTHONPATH"] = pythonpath
    with tempfile.TemporaryDirectory() as folder:
        samples = Path(folder) / "samples.jsonl"
        cmd = [
            sys.executable,
            __file__,
            "--child",
            "--cars",
            str(cars),
            "--duration",
            f"{duration:g}",
            "--every",
            f"{every:g}",
            "--warmup",
            f"{warmup:g}",
            "--samples",
            str(samples),
            "--trace",
            str(trace),
            "--top",
            str(top),
        ]
        result = subprocess.run(cmd, env=env, capture_output=True, text=True, check=False)
        if result.returncode != 0:
            raise SystemExit(f"{' '.join(cmd)} failed ({result.returncode}):\n{result.stderr[-3000:]}")
        rows = [json.loads(line) for line in samples.read_text().splitlines() if line.strip()]
        if keep is not None:
            keep.mkdir(parents=True, exist_ok=True)
            side = "old" if pythonpath is not None and pythonpath != os.environ.get("PYTHONPATH") else "new"
            (keep / f"soak-{cars}car-{duration:g}s-{side}.jsonl").write_text(samples.read_text())
    if trace and "tracemalloc, " in result.stdout:
        print("tracemalloc, " + result.stdout.split("tracemalloc, ", 1)[1], end="")
    after = [r for r in rows if r["t"] >= warmup - 1e-9]
    if len(after) < 4:
        raise SystemExit(f"too few samples after the {warmup:g} s warm-up: use a longer duration or a smaller --every")
    late = [r for r in after if r["t"] >= (after[0]["t"] + after[-1]["t"]) / 2]

    def per_1000_s(key: str, rows: list[dict], unit: float = MB) -> float:
        if any(r[key] is None for r in rows):
            return float("nan")
        return slope([(r["t"], r[key] / unit) for r in rows]) * 1000.0

    moving = [r for r in rows if r["t"] > 0]
    return {
        "rss": after[-1]["rss"] / MB,
        "start": after[0]["anon"] / MB,
        "end": after[-1]["anon"] / MB,
        "slope": per_1000_s("anon", after),
        "late": per_1000_s("anon", late),
        "writer": after[-1]["writer"] / MB,
        "writer_slope": per_1000_s("writer", after),
        "blocks": per_1000_s("blocks", after, 1000.0),
        "malloc": per_1000_s("malloc", after),
        "rtf": (moving[-1]["t"] - moving[0]["t"]) / max(moving[-1]["wall"] - moving[0]["wall"], 1e-9),
    }


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--quick", action="store_true", help="short runs (a check that the bench runs, not figures)")
    p.add_argument("--fleet-cars", type=int, default=4, help="cars in the fleet run (default 4)")
    p.add_argument("--fleet-duration", type=float, help="sim s of the fleet run (default 600; --quick 10)")
    p.add_argument("--solo-duration", type=float, help="sim s of the one-car run (default 3600; --quick 10; 0 skips)")
    p.add_argument("--every", type=float, help="sim s between RSS samples (default 10; --quick 1)")
    p.add_argument("--warmup", type=float, help="sim s left out of the fit (default 60; --quick 3)")
    p.add_argument("--compare", metavar="SRC", help="also run the jobs with PYTHONPATH=SRC (the code before)")
    p.add_argument(
        "--trace",
        type=int,
        default=0,
        metavar="FRAMES",
        help="tracemalloc with this many frames: print what grew (slow; default off)",
    )
    p.add_argument("--top", type=int, default=10, help="with --trace: allocations printed (default 10)")
    p.add_argument("--keep", metavar="DIR", type=Path, help="keep each run's samples there (JSON lines)")
    p.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    p.add_argument("--cars", type=int, default=1, help=argparse.SUPPRESS)
    p.add_argument("--duration", type=float, help=argparse.SUPPRESS)
    p.add_argument("--samples", help=argparse.SUPPRESS)
    args = p.parse_args()
    quick = args.quick
    args.every = args.every or (1.0 if quick else 10.0)
    args.warmup = args.warmup if args.warmup is not None else (3.0 if quick else 60.0)
    if args.child:
        return child(args)
    fleet = args.fleet_duration or (10.0 if quick else 600.0)
    solo = args.solo_duration if args.solo_duration is not None else (10.0 if quick else 3600.0)
    jobs = [(args.fleet_cars, fleet)] + ([(1, solo)] if solo > 0 else [])
    sides = {"new": os.environ.get("PYTHONPATH")} | ({"old": args.compare} if args.compare else {})
    print(
        f"racecar-sim run --world tunnel --no-camera (MCAP and summary.png written): memory every {args.every:g} "
        f"sim s; anon: the run's anonymous resident memory (heap), slopes in MB per 1000 sim s of it after "
        f"{args.warmup:g} s; writer: the recording's writer process",
        flush=True,
    )
    figures = {}
    for cars, duration in jobs:
        for side, path in sides.items():
            figures[f"{cars} car{'s' if cars > 1 else ''}, {duration:g} s", side] = soak(
                cars, duration, args.every, args.warmup, path, args.trace, args.top, args.keep
            )
            print(f"done: {cars} car(s), {duration:g} s, {side}", file=sys.stderr, flush=True)
    print(
        f"{'run':<20}{'side':<6}{'RSS end':>9}{'anon start':>12}{'anon end':>10}{'slope':>8}{'last half':>11}"
        f"{'writer end':>12}{'writer slope':>14}{'RTF':>7}"
    )
    for (name, side), fig in figures.items():
        print(
            f"{name:<20}{side:<6}{fig['rss']:>6.1f} MB{fig['start']:>9.1f} MB{fig['end']:>7.1f} MB"
            f"{fig['slope']:>+8.1f}{fig['late']:>+11.1f}{fig['writer']:>9.1f} MB{fig['writer_slope']:>+14.1f}"
            f"{fig['rtf']:>6.1f}x"
        )
    print("where it grows, after the warm-up: Python's allocator (blocks) and malloc (numpy, MuJoCo, C libraries)")
    print(f"{'run':<20}{'side':<6}{'k blocks/1000 s':>16}{'malloc MB/1000 s':>18}")
    for (name, side), fig in figures.items():
        print(f"{name:<20}{side:<6}{fig['blocks']:>+16.1f}{fig['malloc']:>+18.1f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
