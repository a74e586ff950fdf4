"""`racecar-sim run --ros` and `ros-env` where ROS 1 is missing: one line saying what to install, exit code 2."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path


def test_run_ros_without_rospy_is_one_line_and_exit_2(tmp_path: Path) -> None:
    env = dict(os.environ, RACECAR_SIM_ROS_PYTHON=sys.executable)  # the venv's interpreter: no rospy
    done = subprocess.run(
        [sys.executable, "-m", "racecar_sim", "run", "--ros", "--duration", "0.1", "--out", str(tmp_path / "run")],
        env=env,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert done.returncode == 2
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and "apt-get install ros-core python3-rospy" in lines[0], done.stderr
    assert not (tmp_path / "run").exists()
