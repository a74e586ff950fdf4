"""One set of flags everywhere: run, teleop, launch (and play, which takes run's) accept the same options for the same
things and leave the same run folder; a closed pipe ends quietly; the Python API names Python options."""

from __future__ import annotations

import json
import logging
import os
import subprocess
import sys
from pathlib import Path

import pytest
from mcap.reader import make_reader

from racecar_sim.cli.args import SHARED_OPTIONS
from racecar_sim.cli.main import build_parser

COMMANDS = ["run", "teleop", "launch", "play"]
POSITIONAL = {"launch": ["car.launch"], "play": ["policy.zip"]}
LAUNCH = """<launch>
  <include file="$(find gazebo_ros)/launch/empty_world.launch"><arg name="world_name" value="walker"/></include>
  <param name="robot_description" command="$(find xacro)/xacro '$(find racecar_description)/urdf/racecar.xacro'"/>
  <node name="spawn" pkg="gazebo_ros" type="spawn_model" args="-urdf -param robot_description -model racecar"/>
</launch>
"""


def subparser(command: str):
    parser = build_parser([command])
    (choices,) = [a.choices for a in parser._actions if getattr(a, "choices", None) and command in a.choices]
    return parser, choices[command]


@pytest.mark.parametrize("option", sorted(SHARED_OPTIONS))
@pytest.mark.parametrize("command", COMMANDS)
def test_every_shared_option_is_taken_by_each_command(command, option):
    parser, sub = subparser(command)
    assert option in sub.format_help(), f"{command} --help does not list {option}"
    values = list(SHARED_OPTIONS[option])
    args = parser.parse_args([command, *POSITIONAL.get(command, []), option, *values])
    dest = option.lstrip("-").replace("-", "_")
    default = parser.parse_args([command, *POSITIONAL.get(command, [])])
    assert getattr(args, dest) != getattr(default, dest), f"{command} {option} changed nothing"


def files_and_topics(folder: Path) -> tuple[set[str], dict[str, str]]:
    with open(folder / "run.mcap", "rb") as f:
        summary = make_reader(f).get_summary()
    assert summary is not None
    schemas = {c.topic: summary.schemas[c.schema_id].name for c in summary.channels.values()}
    camera = {topic: schema for topic, schema in schemas.items() if topic.startswith("/camera/")}
    return {p.name for p in folder.iterdir()}, camera


def test_run_and_launch_of_the_same_world_leave_the_same_run_folder(tmp_path):
    (tmp_path / "car.launch").write_text(LAUNCH)
    common = ["--duration", "1", "--seed", "3"]
    for command in (["run", "--world", "walker", "--driver", "constant", "--speed", "0"], ["launch", "car.launch"]):
        result = subprocess.run(
            [sys.executable, "-m", "racecar_sim", *command, *common, "--out", command[0]],
            capture_output=True,
            text=True,
            timeout=300,
            cwd=tmp_path,
        )
        assert result.returncode == 0, result.stderr
        for name in ("summary.png", "summary.json", "run.mcap", "camera.mp4"):
            assert f"wrote            {command[0]}/{name}" in result.stdout, result.stdout
    run_files, run_camera = files_and_topics(tmp_path / "run")
    launch_files, launch_camera = files_and_topics(tmp_path / "launch")
    assert run_files == launch_files == {"run.mcap", "summary.png", "summary.json", "camera.mp4"}
    # camera images as JPEG CompressedImage in both (launch recorded raw images before: 130 MB for 20 s)
    compressed = {"/camera/zed/rgb/image_rect_color/compressed": "sensor_msgs/msg/CompressedImage"}
    assert {t: s for t, s in run_camera.items() if "image" in t} == compressed
    assert {t: s for t, s in launch_camera.items() if "image" in t} == compressed
    run_summary = json.loads((tmp_path / "run" / "summary.json").read_text())
    launch_summary = json.loads((tmp_path / "launch" / "summary.json").read_text())
    assert set(run_summary) <= set(launch_summary) and set(run_summary["cars"]) == set(launch_summary["cars"])
    assert set(run_summary["cars"]["racecar"]) == set(launch_summary["cars"]["racecar"])
    assert launch_summary["world"] == run_summary["world"] == "walker"
    assert launch_summary["cars"]["racecar"]["driver"] == "none"


def test_a_launch_file_that_starts_no_driver_says_how_to_drive(tmp_path):
    (tmp_path / "car.launch").write_text(LAUNCH)
    command = [sys.executable, "-m", "racecar_sim", "launch", "car.launch", "--duration", "0.2", "--no-camera"]
    quiet = subprocess.run(command, capture_output=True, text=True, timeout=300, cwd=tmp_path)
    assert quiet.returncode == 0, quiet.stderr
    (hint,) = [line for line in quiet.stderr.splitlines() if "starts no driver" in line]
    assert "--driver" in hint and "ROS node" in hint and "--viewer" in hint
    driven = subprocess.run([*command, "--driver", "wall-follow"], capture_output=True, text=True, timeout=300,
                            cwd=tmp_path)  # fmt: skip
    assert driven.returncode == 0 and "starts no driver" not in driven.stderr, driven.stderr


@pytest.mark.parametrize("command", [["describe", "--urdf"], ["worlds"], ["run", "--help"]])
def test_a_closed_pipe_ends_quietly(command):
    process = subprocess.Popen(
        [sys.executable, "-m", "racecar_sim", *command], stdout=subprocess.PIPE, stderr=subprocess.PIPE
    )
    assert process.stdout is not None and process.stderr is not None
    process.stdout.readline()
    process.stdout.close()  # as `| head -1` does
    stderr = process.stderr.read().decode()
    code = process.wait(timeout=120)
    assert "Traceback" not in stderr and "BrokenPipeError" not in stderr and stderr == "", stderr
    assert code in (0, 141)


def test_teleop_refuses_fast_in_one_line(tmp_path):
    result = subprocess.run(
        [sys.executable, "-m", "racecar_sim", "teleop", "--fast", "--viewer"], capture_output=True, text=True,
        timeout=120, cwd=tmp_path,
    )  # fmt: skip
    assert result.returncode == 2
    assert result.stderr.strip() == (
        "racecar-sim: error: teleop runs in real time, as a person drives: --fast is for run and launch"
    )


def test_the_gymnasium_env_names_its_python_option_when_there_is_no_display(monkeypatch, caplog):
    gym = pytest.importorskip("gymnasium")
    import racecar_sim.envs  # noqa: F401  (registers the ids)

    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    env = gym.make("racecar_sim/Drive-v0", world="empty", render_mode="human")
    try:
        env.reset(seed=0)
        with caplog.at_level(logging.WARNING):
            env.render()
    finally:
        env.close()
    warnings = [r.getMessage() for r in caplog.records if "headless" in r.getMessage()]
    assert warnings and warnings[0].startswith("render_mode='human': no display"), warnings
    assert not any("--viewer" in w for w in warnings)


def test_worlds_show_prints_the_path_written(tmp_path):
    result = subprocess.run(
        [sys.executable, "-m", "racecar_sim", "worlds", "--show", "empty"], capture_output=True, text=True,
        timeout=120, cwd=tmp_path, env={**os.environ},
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    # into runs/ (issue 35: the repo's root stays clean), the path it prints is the file's
    assert result.stdout.strip() == str(tmp_path / "runs" / "empty.png") and (tmp_path / "runs" / "empty.png").is_file()
    assert not (tmp_path / "empty.png").exists()


def test_teleop_out_leaves_the_run_folder(tmp_path):
    pexpect = pytest.importorskip("pexpect")
    child = pexpect.spawn(
        "bash",
        ["-c", f"{sys.executable} -m racecar_sim teleop --world walker --no-camera --duration 1 --out {tmp_path}"],
        timeout=120,
        encoding="utf-8",
        dimensions=(24, 250),
    )
    child.expect(pexpect.EOF)
    child.close()
    assert child.exitstatus == 0, child.before
    assert {p.name for p in tmp_path.iterdir()} == {"run.mcap", "summary.png", "summary.json"}
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["world"] == "walker" and summary["cars"]["racecar"]["driver"] == "keyboard (keyboard_teleop)"
    assert f"wrote            {tmp_path}/summary.json" in child.before and "crashes          0" in child.before
    with open(tmp_path / "run.mcap", "rb") as f:
        assert make_reader(f).get_summary().statistics.message_count > 100
