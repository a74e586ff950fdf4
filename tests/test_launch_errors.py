"""Malformed launch inputs: one line naming the file (and line), the element and the fix; exit code 2."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

SPAWN = (
    '<param name="robot_description" command="$(find xacro)/xacro $(find racecar_description)/urdf/racecar.xacro"/>'
    '\n  <node name="spawn" pkg="gazebo_ros" type="spawn_model" args="-urdf -param robot_description"/>'
)
CASES = {
    # name: (launch file body, command-line args, what the one line must say)
    "bad_xml": (
        "<launch>\n  <arg name='a' default='1'>\n</launch>\n",
        [],
        ["bad.launch:3", "bad XML", "mismatched tag"],
    ),
    "unknown_substitution": (
        "<launch>\n  <param name='p' value='$(fnd racecar)/x'/>\n</launch>\n",
        [],
        ["bad.launch:2", '<param name="p">', "unknown substitution $(fnd racecar)", "$(find ...)"],
    ),
    "missing_package": (
        "<launch>\n  <include file='$(find no_such_package_xyz)/launch/a.launch'/>\n</launch>\n",
        [],
        ["bad.launch:2", "<include file=", "no_such_package_xyz", "--package-path"],
    ),
    "missing_arg": (
        "<launch>\n  <arg name='world_name'/>\n</launch>\n",
        [],
        ["bad.launch:2", '<arg name="world_name">', "has no value", "world_name:=VALUE"],
    ),
    "undeclared_arg": (
        "<launch>\n  <arg name='a' default='1'/>\n</launch>\n",
        ["b:=2"],
        ["bad.launch", "b given on the command line", "not declared", "declare it"],
    ),
    "missing_include": (
        "<launch>\n  <include file='$(dirname)/nowhere.launch'/>\n</launch>\n",
        [],
        ["bad.launch:2", "nowhere.launch does not exist", "check the path"],
    ),
    "required_ros_node": (
        f"<launch>\n  {SPAWN}\n  <node name='planner' pkg='my_planner' type='plan.py' required='true'/>\n</launch>\n",
        [],
        ["bad.launch:4", '<node name="planner">', "/planner (my_planner/plan.py)", "--ros"],
    ),
    "not_a_launch_file": ("<robot name='x'/>\n", [], ["bad.launch:1", '<robot name="x">', "not <launch>"]),
    "shell_command": (
        "<launch>\n  <param name='d' command='rosrun xacro xacro x.xacro'/>\n</launch>\n",
        [],
        ["bad.launch:2", '<param name="d">', "'rosrun' is not run by the sim", "value= or textfile="],
    ),
    "no_car": (
        "<launch>\n  <node name='n' pkg='racecar_sim' type='constant'/>\n</launch>\n",
        [],
        ["bad.launch", "no gazebo_ros spawn_model node", "spawn one"],
    ),
}


def launch(tmp_path: Path, body: str, *args: str) -> subprocess.CompletedProcess:
    path = tmp_path / "bad.launch"
    path.write_text(body)
    return subprocess.run(
        [
            sys.executable,
            "-m",
            "racecar_sim",
            "launch",
            str(path),
            *args,
            "--duration",
            "0.1",
            "--no-camera",
            "--no-lidar",
        ],
        capture_output=True,
        text=True,
        timeout=120,
    )


@pytest.mark.parametrize("case", sorted(CASES))
def test_malformed_launch_inputs_give_one_line_and_exit_code_2(case, tmp_path):
    body, args, expected = CASES[case]
    result = launch(tmp_path, body, *args)
    assert result.returncode == 2, result.stderr
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("racecar-sim: error: "), result.stderr
    assert "Traceback" not in result.stderr
    for part in expected:
        assert part in lines[0], lines[0]


def test_a_missing_launch_file_and_a_malformed_cli_arg(tmp_path):
    result = subprocess.run(
        [sys.executable, "-m", "racecar_sim", "launch", str(tmp_path / "none.launch")],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert result.returncode == 2 and result.stderr.strip() == (
        f"racecar-sim: error: {tmp_path / 'none.launch'}: no such launch file; check the path"
    )
    result = subprocess.run(
        [sys.executable, "-m", "racecar_sim", "launch", str(tmp_path / "x.launch"), "a=1"],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert result.returncode == 2 and "'a=1' is not name:=value" in result.stderr


def test_a_node_the_sim_cannot_run_is_a_warning_unless_required(tmp_path):
    body = f"<launch>\n  {SPAWN}\n  <node name='planner' pkg='my_planner' type='plan.py'/>\n</launch>\n"
    result = launch(tmp_path, body)
    assert result.returncode == 0, result.stderr
    warning = [line for line in result.stderr.splitlines() if "/planner" in line]
    assert len(warning) == 1 and "bad.launch:4" in warning[0] and "run with --ros" in warning[0]
