"""The speed benches run: `racecar-sim bench --speed --quick` (bench/bench_speed.py and the five benches behind the
speed figures) finishes and prints every table; so do the memory soak (bench/bench_soak.py --quick) and the ROS 1
bridge's throughput bench (bench/bench_ros_bridge.py --quick). A check that they do not rot, not a timing test."""

from __future__ import annotations

import importlib.util
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from conftest import needs_gl
from racecar_sim.bridges.ros1 import ros_available
from racecar_sim.core.machine import cpu_model


def test_speed_benches_run_and_print_their_tables():
    result = subprocess.run(
        [sys.executable, "-m", "racecar_sim", "bench", "--speed", "--quick"],
        capture_output=True,
        text=True,
        timeout=600,
        check=False,
    )
    assert result.returncode == 0, result.stderr[-3000:]
    out = result.stdout
    for header in ("1. main job", "2. lidar pipeline", "3. start-up", "4. real maps", "5. scaling", "6. fleets"):
        assert f"=== {header}" in out
    assert out.startswith("CPU "), out[:200]  # the machine the figures belong to
    for line in (
        "main job (camera, noise, MCAP, video)",
        "tunnel ",
        "walker ",
        "start -> first physics step",
        "import racecar_sim.msgs",
        "floor: import numpy, mujoco",
        "basement-like (generated)",
        "lidar beams (tunnel)",
        "cars in empty",
        "world    cars  real-time factor  bare MuJoCo  ratio  car-s per wall s",
        "track       4",
        "racecar-sim run --world empty --cars N --driver constant --speed 1",  # the fleet as users run it
        "world    recording cars  real-time factor  bare MuJoCo  ratio  loop ratio  outside loop  bare process  "
        "process ratio",  # bare MuJoCo as a whole process too: its start, import and compile included
        "empty          off    2",  # the CLI's row, recording off
        "empty           on    2",  # and on
    ):
        assert line in out, line


def test_startup_bench_quick_prints_the_ratios_to_the_floor():
    """bench/bench_startup.py --quick: the CPU model, the numpy + mujoco floor, and both short runs (empty without
    the camera, walker with it) start to exit and as a ratio to the floor."""
    bench = Path(__file__).resolve().parents[1] / "bench" / "bench_startup.py"
    result = subprocess.run(
        [sys.executable, str(bench), "--quick"], capture_output=True, text=True, timeout=600, check=False
    )
    assert result.returncode == 0, result.stderr[-3000:]
    out = result.stdout
    assert out.startswith("CPU "), out
    floor = re.search(r"\(r\) floor: import numpy, mujoco; compile a one-geom model +([0-9.]+) s", out)
    assert floor is not None and float(floor[1]) > 0, out
    for world in ("empty", "walker"):
        row = re.search(rf"\({world[0]}\) {world}.* start -> exit +([0-9.]+) s .* x([0-9.]+) the floor", out)
        assert row is not None and float(row[1]) > 0 and float(row[2]) > 0, out
    for line in ("start -> first physics step", "import racecar_sim.msgs", "whole command, start -> exit"):
        assert line in out, line


def test_writer_bench_quick_replays_a_run_through_the_writer_process():
    """bench/bench_writer.py --quick: a 1 s main job's hand-overs (its messages, its camera frames as JPEG and video)
    replayed through a writer process, whose CPU it prints."""
    bench = Path(__file__).resolve().parents[1] / "bench" / "bench_writer.py"
    result = subprocess.run(
        [sys.executable, str(bench), "--quick"], capture_output=True, text=True, timeout=600, check=False
    )
    assert result.returncode == 0, result.stderr[-3000:]
    out = result.stdout
    assert out.startswith("CPU "), out
    row = re.search(r"round 1/1: new writer process ([0-9.]+) s CPU \(([0-9.]+) s wall, (\d+) frames\)", out)
    assert row is not None and float(row[1]) > 0 and int(row[3]) >= 25, out  # the camera's 30 Hz, 1 sim s
    assert re.search(r"new +[0-9.]+ s, \d+ ms a sim second", out), out


def test_soak_bench_runs_and_prints_its_table():
    """bench/bench_soak.py --quick: the memory slopes of a short fleet run and a short one-car run."""
    bench = Path(__file__).resolve().parents[1] / "bench" / "bench_soak.py"
    result = subprocess.run(
        [sys.executable, str(bench), "--quick"], capture_output=True, text=True, timeout=600, check=False
    )
    assert result.returncode == 0, result.stderr[-3000:]
    for line in ("anon start", "4 cars, 10 s", "1 car, 10 s", "k blocks/1000 s"):
        assert line in result.stdout, line


@pytest.mark.skipif(
    not (Path("/usr/bin/roscore").exists() and ros_available()),
    reason="ROS 1 is not installed (apt-get install ros-core python3-rospy ...)",
)
def test_ros_bridge_bench_quick_prints_the_ratio():
    """bench/bench_ros_bridge.py --quick: both sims run in turns and the bridged/unbridged real-time factor ratio is
    printed (a check that it runs, not of the figure)."""
    bench = Path(__file__).resolve().parents[1] / "bench" / "bench_ros_bridge.py"
    result = subprocess.run(
        [sys.executable, str(bench), "--quick"], capture_output=True, text=True, timeout=300, check=False
    )
    assert result.returncode == 0, result.stderr[-3000:]
    for line in ("without bridge", "with --ros --fast", "/scan, /vesc/odom, /tf, /clock"):
        assert line in result.stdout, line
    ratio = re.search(r"^ratio\s+([0-9.]+)$", result.stdout, re.MULTILINE)
    assert ratio is not None and float(ratio[1]) > 0, result.stdout


@pytest.mark.skipif(
    importlib.util.find_spec("mujoco_warp") is None or os.environ.get("RACECAR_SIM_TEST_WARP") == "0",
    reason="needs mujoco-warp (the [gpu] extra); RACECAR_SIM_TEST_WARP=0 skips it",
)
def test_gpu_bench_quick_prints_its_table():
    """bench/bench_gpu.py --quick: the MuJoCo Warp batch on Warp's CPU device at 1 and 8 worlds against the CPU batch,
    the table and its trajectory check printed (~30 s the first time: Warp compiles its kernels; then ~10 s)."""
    bench = Path(__file__).resolve().parents[1] / "bench" / "bench_gpu.py"
    result = subprocess.run(
        [sys.executable, str(bench), "--quick"], capture_output=True, text=True, timeout=600, check=False
    )
    assert result.returncode == 0, result.stderr[-3000:]
    out = result.stdout
    assert "device cpu (" in out and "computed on the HOST" in out
    assert "worlds  device car-steps/s   CPU car-steps/s    ratio  host lidar" in out
    rows = re.findall(r"^ +(\d+) +([\d,]+) +[\d,]+ +[\d.]+ +\d+% +\d+ +\S+ +\S+ +\S+ +(yes|NO.*)$", out, re.MULTILINE)
    assert [int(row[0]) for row in rows] == [1, 8], out
    assert all(int(row[1].replace(",", "")) > 0 for row in rows), out


def test_gpu_bench_without_a_gpu_is_one_line():
    """bench/bench_gpu.py --device warp on a machine without a CUDA GPU (or without mujoco-warp): what is missing in
    one line, exit 2."""
    if importlib.util.find_spec("warp") is not None:
        import warp

        warp.config.log_level = warp.LOG_ERROR
        if warp.get_cuda_device_count():
            pytest.skip("this machine has a CUDA GPU")
    bench = Path(__file__).resolve().parents[1] / "bench" / "bench_gpu.py"
    result = subprocess.run(
        [sys.executable, str(bench), "--device", "warp", "--worlds", "1"],
        capture_output=True,
        text=True,
        timeout=300,
        check=False,
    )
    assert result.returncode == 2, result.stderr[-3000:]
    assert result.stdout == ""
    (line,) = result.stderr.splitlines()
    assert line.startswith("bench_gpu.py: error: ") and "[gpu]" in line, line


def test_dynamics_bench_runs_and_draws_its_pictures(tmp_path):
    """bench/bench_dynamics.py --quick: the circle table, the g-g diagram and understeer curve, the tyres' cost."""
    bench = Path(__file__).resolve().parents[1] / "bench" / "bench_dynamics.py"
    result = subprocess.run(
        [sys.executable, str(bench), "--quick", "--out", str(tmp_path)],
        capture_output=True,
        text=True,
        timeout=900,
        check=False,
    )
    assert result.returncode == 0, result.stderr[-3000:]
    for line in ("| seed | 0.1 | 4 |", "| f1tenth | 0.3 | 2 |", "understeer f1tenth", "one car", "fleet of 4, f1tenth"):
        assert line in result.stdout, line
    assert (tmp_path / "dynamics_gg.png").stat().st_size > 10_000
    assert (tmp_path / "dynamics_understeer.png").stat().st_size > 10_000


def test_jacobian_bench_prints_a_row_per_fleet():
    """bench/bench_jacobian.py: the CPU, then each fleet's dofs, its step each way and the way it steps."""
    bench = Path(__file__).resolve().parents[1] / "bench" / "bench_jacobian.py"
    result = subprocess.run(
        [sys.executable, str(bench), "--cars", "2", "17", "--rounds", "1"],
        capture_output=True,
        text=True,
        timeout=600,
        check=False,
    )
    assert result.returncode == 0, result.stderr[-3000:]
    lines = result.stdout.splitlines()
    assert lines[0].startswith("CPU "), lines[0]
    rows = [line.split() for line in lines[2:]]
    assert [row[:2] for row in rows] == [["2", "24"], ["17", "204"]], result.stdout  # 12 dofs a car
    assert all(float(value) > 0 for row in rows for value in row[2:5]), result.stdout
    assert [" ".join(row[5:7]) for row in rows] == ["dense Newton:", "sparse CG:"], result.stdout


def test_the_rtf_bench_names_the_cpu_it_ran_on():
    """`racecar-sim bench` prints the CPU model above its figures: the one the kernel reports (lscpu's Model name,
    where lscpu is installed)."""
    result = subprocess.run(
        [sys.executable, "-m", "racecar_sim", "bench", "--no-camera", "--duration", "0.2", "--repeat", "1"],
        capture_output=True,
        text=True,
        timeout=600,
        check=False,
    )
    assert result.returncode == 0, result.stderr[-3000:]
    first = result.stdout.splitlines()[0]
    assert first.startswith(f"CPU {cpu_model()}, ") and " cores (" in first, first
    if shutil.which("lscpu"):
        lscpu = subprocess.run(["lscpu"], capture_output=True, text=True, check=True, env={"LC_ALL": "C"}).stdout
        names = [line.split(":", 1)[1].strip() for line in lscpu.splitlines() if line.startswith("Model name:")]
        if names:
            assert " ".join(names[0].split()) == cpu_model()


@needs_gl
def test_camera_bench_prints_the_cpu_of_a_frame_by_thread():
    """bench/bench_camera.py: frames per second, and a full frame's CPU on the taking thread, the GL thread and
    llvmpipe's, with the geoms a frame draws."""
    bench = Path(__file__).resolve().parents[1] / "bench" / "bench_camera.py"
    result = subprocess.run(
        [sys.executable, str(bench), "--frames", "5", "--worlds", "walker"],
        capture_output=True,
        text=True,
        timeout=600,
        check=False,
    )
    assert result.returncode == 0, result.stderr[-3000:]
    assert "CPU ms main / GL / llvmpipe" in result.stdout, result.stdout
    row = re.search(r"^walker .* ([0-9.]+) / ([0-9.]+) / ([0-9.]+) +([0-9.]+)$", result.stdout, re.M)
    assert row is not None, result.stdout
    main, gl, geoms = float(row[1]), float(row[2]), float(row[4])
    assert main > 0 and gl > 0 and 0 < geoms < 69  # walker's model has 69 geoms: some are culled
