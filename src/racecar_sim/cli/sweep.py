"""`racecar-sim sweep FILE.yaml`: many episodes (worlds x drivers and their parameters x seeds) on Ray.

OUT (default sweeps/<date-time>) then holds results.csv (and results.parquet with pyarrow), a row per episode,
runs/<index>-<world>-<driver>-seed<k>/ with each episode's run.mcap and summary.json, and sweep.yaml, the file
as run. `--local` runs the episodes one by one in this process, without Ray.
"""

from __future__ import annotations

import argparse
import sys
from datetime import datetime
from pathlib import Path
from typing import Any

from tqdm import tqdm

from racecar_sim.cli.args import check_folder, positive_int
from racecar_sim.core.errors import ConfigError
from racecar_sim.sweep import load_sweep, run_sweep
from racecar_sim.sweep.ray_runner import INSTALL_HINT, ray_available


def add_parser(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser(
        "sweep",
        help="many episodes over worlds, seeds, drivers and their parameters on Ray; writes "
        "results.csv/.parquet and each run's MCAP and summary",
    )
    p.add_argument(
        "file",
        metavar="FILE.yaml",
        help="the sweep: worlds, seeds, drivers and their parameters, duration (see examples/sweep_wall_follow.yaml)",
    )
    p.add_argument("--out", metavar="DIR", help="folder for the results (default sweeps/<date-time>)")
    p.add_argument(
        "--address",
        metavar="ADDR",
        help="the Ray cluster to run on (host:port, ray://host:10001, auto); default: RAY_ADDRESS, a Ray "
        "started on this machine with `ray start`, else a local Ray for this sweep",
    )
    p.add_argument(
        "--num-cpus",
        type=positive_int,
        metavar="N",
        help="CPUs of the local Ray, one episode on each at a time (default: all)",
    )
    p.add_argument("--local", action="store_true", help="no Ray: run the episodes one by one in this process")


def main(args: argparse.Namespace) -> int:
    spec = load_sweep(args.file)
    if args.local and (args.address or args.num_cpus):
        raise ConfigError("--local runs here, one episode at a time: drop --address and --num-cpus")
    if not args.local and not ray_available():
        raise ConfigError(INSTALL_HINT)
    out = Path(args.out) if args.out else Path("sweeps") / datetime.now().strftime("%Y%m%d-%H%M%S")
    check_folder("--out", out)
    episodes = spec.size  # counted: the episodes are made one at a time as they run
    where = "here, one by one" if args.local else f"on Ray ({args.address or 'local or RAY_ADDRESS'})"
    print(f"sweep {args.file}: {episodes} episodes of {spec.settings.duration:g} s sim, {where}", file=sys.stderr)
    bar = tqdm(total=episodes, unit="episode", file=sys.stderr)

    def progress(row: dict[str, Any]) -> None:
        bar.set_postfix_str(
            f"last: #{row['index']} {row['world']} {row['driver']} seed {row['seed']}"
            + (" FAILED" if row.get("error") else ""),
            refresh=False,
        )
        bar.update(1)

    try:
        result = run_sweep(spec, out, local=args.local, address=args.address, num_cpus=args.num_cpus, on_row=progress)
    finally:
        bar.close()
    for row in result.failed:
        print(f"racecar-sim: episode {row['index']} ({row['folder']}) failed: {row['error']}", file=sys.stderr)
    print(f"{len(result.rows) - len(result.failed)} of {len(result.rows)} episodes ran")
    for path in result.tables:
        print(f"wrote            {path}")
    print(f"runs             {out / 'runs'}")
    return 1 if result.failed else 0
