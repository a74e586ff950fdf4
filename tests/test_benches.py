"""The speed benches run: `racecar-sim bench --speed --quick` (bench/bench_speed.py and the five benches behind the
speed figures) finishes and prints every table; so do the memory soak (bench/bench_soak.py --quick) and the ROS 1
bridge's throughput bench (bench/bench_ros_bridge.py --quick). A check that they do not rot, not a timing test."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest

from racecar_sim.bridges.ros1 import ros_available


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
    for line in (
        "main job (camera, noise, MCAP, video)",
        "tunnel ",
        "walker ",
        "start -> first physics step",
        "import racecar_sim.msgs",
        "basement-like (generated)",
        "lidar beams (tunnel)",
        "cars in empty",
        "world    cars  real-time factor  bare MuJoCo  ratio  car-s per wall s",
        "track       4",
    ):
        assert line in out, line


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
