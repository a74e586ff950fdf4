"""Start-up: seconds from process start to exit of short `racecar-sim run`s against Python and MuJoCo's own floor,
to the first physics step, and import costs.

Prints the CPU model, then, each the median of --repeats fresh processes (interleaved):
  (r) the floor: a process that imports numpy and mujoco and compiles a one-geom model;
  (e) `racecar-sim run --world empty --no-camera --no-record --no-video --no-summary --duration 0.01`, start to exit,
      and its ratio to (r): each run paired with a floor process right before it, the median of the pairs' ratios;
  (w) the same in walker with the camera, `--duration 0.1` (it renders, scans and loads the compiled kernels);
  (a) process start -> first mj_step of `racecar-sim run --no-camera --world empty --duration 1`;
  (b) `import racecar_sim.msgs` alone, and whether it imported mujoco, trimesh or scipy;
  (c) the whole command's wall time (to exit: the run, run.mcap and summary.png).
Every child runs as an installed package does: with its bytecode cached (PYTHONDONTWRITEBYTECODE is dropped from
its environment) and after one untimed run of each command (numba's cache filled, as after a first run).
`--quick` runs each once: a check that the bench runs, not figures to quote.

The first step is seen from outside the product: the child process puts a finder on sys.meta_path that wraps
`mujoco.mj_step` as soon as mujoco is imported and writes the monotonic clock at its first call to a file. Only
the CLI is used, so the same script measures the pristine base:

    PYTHONPATH=/work/base/src python bench/bench_startup.py

or both in one run, interleaved, each figure also as a ratio to the first tree's (load from other processes then
falls on all trees alike):

    python bench/bench_startup.py --compare /work/base/src src
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from racecar_sim.core.machine import machine_line

RUN_ARGS = ["run", "--no-camera", "--world", "empty", "--duration", "1"]
QUIET = ["--no-record", "--no-video", "--no-summary"]
EMPTY_ARGS = ["run", "--world", "empty", "--no-camera", *QUIET, "--duration", "0.01"]
WALKER_ARGS = ["run", "--world", "walker", *QUIET, "--duration", "0.1"]
FLOOR = """import numpy, mujoco
mujoco.MjModel.from_xml_string("<mujoco><worldbody><geom size='1'/></worldbody></mujoco>")"""
CLI = "import sys; from racecar_sim.cli.main import main; sys.argv[0] = 'racecar-sim'; sys.exit(main())"
HEAVY = ("mujoco", "trimesh", "scipy", "matplotlib")

# the child: mark the first mj_step, then run the CLI exactly as the console script does
_CHILD = r"""
import importlib.abc, importlib.machinery, sys, time
MARK = sys.argv[1]

class _Wrap(importlib.abc.MetaPathFinder):
    def find_spec(self, name, path, target=None):
        if name != "mujoco":
            return None
        sys.meta_path.remove(self)
        spec = importlib.machinery.PathFinder.find_spec(name, path)
        run = spec.loader.exec_module
        def exec_module(module):
            run(module)
            step = module.mj_step
            def first(*args, **kwargs):
                module.mj_step = step
                with open(MARK, "w") as f:
                    f.write(repr(time.monotonic()))
                return step(*args, **kwargs)
            module.mj_step = first
        spec.loader.exec_module = exec_module
        return spec

sys.meta_path.insert(0, _Wrap())
from racecar_sim.cli.main import main
sys.argv = ["racecar-sim", *sys.argv[2:]]
sys.exit(main())
"""

_IMPORT = r"""
import json, sys, time
t = time.perf_counter()
import racecar_sim.msgs
dt = time.perf_counter() - t
print(json.dumps({"seconds": dt, "loaded": [m for m in HEAVY if m in sys.modules],
                  "file": racecar_sim.__file__}))
""".replace("HEAVY", repr(HEAVY))


def _env(src: str | None) -> dict[str, str]:
    """The environment of a child importing racecar_sim from `src` (None: as this process would), bytecode cached."""
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    if src is None:
        return env
    paths = [str(Path(src).resolve()), *filter(None, os.environ.get("PYTHONPATH", "").split(os.pathsep))]
    return {**env, "PYTHONPATH": os.pathsep.join(paths)}


def _children_cpu() -> float:
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


CPU: dict[str, list[float]] = {}  # CPU seconds (user + system) of each command's runs, by its arguments


def wall(code: str, args: list[str], workdir: Path, src: str | None = None) -> float:
    """Seconds from start to exit of `python -c code args...` in a fresh process (SystemExit on failure); its CPU
    seconds go to CPU (less moved than wall time by other processes on a shared machine)."""
    start, cpu = time.monotonic(), _children_cpu()
    result = subprocess.run(
        [sys.executable, "-c", code, *args], capture_output=True, text=True, cwd=workdir, env=_env(src), check=False
    )
    seconds = time.monotonic() - start
    CPU.setdefault(" ".join([str(src), *args[:8]]), []).append(_children_cpu() - cpu)
    if result.returncode != 0:
        raise SystemExit(
            f"{' '.join(args) or 'the floor process'} failed ({result.returncode}): {result.stderr.strip()[-2000:]}"
        )
    return seconds


def floor_pair(args: list[str], workdir: Path, src: str | None = None) -> tuple[float, float]:
    """(floor seconds, `racecar-sim ARGS` seconds), one right after the other: load from other processes falls on
    both alike."""
    out = workdir / "pair"
    shutil.rmtree(out, ignore_errors=True)
    return wall(FLOOR, [], workdir), wall(CLI, [*args, "--out", str(out)], workdir, src)


def first_step(workdir: Path, src: str | None = None) -> tuple[float, float]:
    """(seconds to the first mj_step, seconds to exit) of one `racecar-sim run` in a fresh process."""
    mark = workdir / "first_step"
    mark.unlink(missing_ok=True)
    out = workdir / "run"
    # each run writes a folder of its own: a run never replaces a recording unasked (and an older checkout's run
    # takes no --overwrite)
    shutil.rmtree(out, ignore_errors=True)
    start = time.monotonic()
    result = subprocess.run(
        [sys.executable, "-c", _CHILD, str(mark), *RUN_ARGS, "--out", str(out)],
        capture_output=True,
        text=True,
        cwd=workdir,
        env=_env(src),
        check=False,
    )
    end = time.monotonic()
    if result.returncode != 0 or not mark.exists():
        raise SystemExit(f"the run failed ({result.returncode}): {result.stderr.strip()[-2000:]}")
    return float(mark.read_text()) - start, end - start


def msgs_import(src: str | None = None) -> dict:
    """`import racecar_sim.msgs` in a fresh process: its seconds, which heavy modules it loaded, the package file."""
    result = subprocess.run([sys.executable, "-c", _IMPORT], capture_output=True, text=True, check=True, env=_env(src))
    return json.loads(result.stdout)


def python_start() -> float:
    """Seconds for a bare `python -c pass`: the floor under every figure above."""
    start = time.monotonic()
    subprocess.run([sys.executable, "-c", "pass"], check=True)
    return time.monotonic() - start


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=7, help="fresh processes per figure (median; default 7)")
    parser.add_argument(
        "--compare",
        nargs="+",
        metavar="SRC",
        default=[None],
        help="source trees (each put first on PYTHONPATH), measured interleaved",
    )
    parser.add_argument("--quick", action="store_true", help="each once: a check that it runs, not figures to quote")
    args = parser.parse_args()
    repeats = 1 if args.quick else args.repeats
    figures = {
        src: {key: [] for key in ("first", "wall", "import", "empty", "walker", "empty/", "walker/")}
        | {"loaded": set(), "file": ""}
        for src in args.compare
    }
    bare: list[float] = []
    floor: list[float] = []
    pairs = {"empty": EMPTY_ARGS, "walker": WALKER_ARGS}
    with tempfile.TemporaryDirectory() as tmp:
        workdir = Path(tmp)
        for src in figures:  # untimed: bytecode and numba's cache written, as after an install and a first run
            for run_args in pairs.values():
                floor_pair(run_args, workdir, src)
        CPU.clear()
        for _ in range(repeats):  # interleaved, so load from other processes falls on all figures alike
            for src, fig in figures.items():
                for key, run_args in pairs.items():
                    ref, cli = floor_pair(run_args, workdir, src)
                    floor.append(ref)
                    fig[key].append(cli)
                    fig[key + "/"].append(cli / ref)
                    fig[key + " cpu"] = CPU[" ".join([str(src), *run_args[:8]])]
                first, whole = first_step(workdir, src)
                fig["first"].append(first)
                fig["wall"].append(whole)
                info = msgs_import(src)
                fig["import"].append(info["seconds"])
                fig["loaded"] |= set(info["loaded"])
                fig["file"] = os.path.dirname(os.path.dirname(info["file"]))
            bare.append(python_start())
    median = statistics.median
    reference = figures[args.compare[0]]
    quick = " (--quick: a check that it runs, not figures to quote)" if args.quick else ""
    print(machine_line())
    print(f"{repeats} runs each, medians; python -c pass {median(bare):.3f} s{quick}")
    floor_cpu = CPU[str(None)]
    print(
        f"  (r) floor: import numpy, mujoco; compile a one-geom model   {median(floor):6.3f} s   "
        f"(CPU {median(floor_cpu):.3f} s)"
    )

    def show(fig: dict, key: str) -> str:
        ratio = "" if fig is reference else f"  x{median(fig[key]) / median(reference[key]):.2f}"
        return f"{median(fig[key]):6.3f} s (min {min(fig[key]):.3f}){ratio}"

    for fig in figures.values():
        print(f"racecar_sim from {fig['file']}")
        for key, label in (("empty", "(e) empty, no camera, 0.01 s"), ("walker", "(w) walker, camera, 0.1 s  ")):
            print(
                f"  {label}  start -> exit {show(fig, key)}   x{median(fig[key + '/']):.2f} the floor   "
                f"(CPU {median(fig[key + ' cpu']):.3f} s, x{median(fig[key + ' cpu']) / median(floor_cpu):.2f})   "
                f"`racecar-sim {' '.join(pairs[key])}`"
            )
        print(f"  (a) start -> first physics step   {show(fig, 'first')}   `racecar-sim {' '.join(RUN_ARGS)}`")
        print(
            f"  (b) import racecar_sim.msgs       {show(fig, 'import')}   loaded: "
            f"{', '.join(sorted(fig['loaded'])) or 'none'} of {', '.join(HEAVY)}"
        )
        print(f"  (c) whole command, start -> exit  {show(fig, 'wall')}")


if __name__ == "__main__":
    main()
