"""The first hour of a new user (issue 10): the flags users type, bad commands and bad configuration.

Every CLI failure here must be one line on stderr, exit code 2 and no traceback; a NaN command must stop
the car as a silent driver does; a diverging physics must stop the run with the recording intact.
"""

from __future__ import annotations

import logging
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml
from rosbags.highlevel import AnyReader
from rosbags.typesys import Stores, get_typestore

from conftest import NAVIGATION, Log, ground_speed
from racecar_sim import Simulator
from racecar_sim.control.controllers import load_controller_config
from racecar_sim.control.mux import load_mux_inputs
from racecar_sim.core.errors import ConfigError, PhysicsError
from racecar_sim.core.tables import table_entry
from racecar_sim.description import load_robot, package_path
from racecar_sim.drivers import ConstantCommand
from racecar_sim.msgs import AckermannDrive, AckermannDriveStamped, Float64, Header
from racecar_sim.physics import PhysicsPreset

CLI = [sys.executable, "-m", "racecar_sim"]
QUIET = ["--no-camera", "--no-summary", "--no-video"]
CONTROLLERS = package_path("racecar_control") / "config" / "racecar_control.yaml"
WALL_FOLLOW_YAML = Path(__import__("racecar_sim.drivers", fromlist=["x"]).__file__).parent / "data" / "wall_follow.yaml"
HIGH_ACTIVE = "/vesc/high_level/ackermann_cmd_mux/active"


def run_cli(*args: str, cwd: Path | None = None, timeout: float = 120) -> subprocess.CompletedProcess:
    return subprocess.run([*CLI, *args], capture_output=True, text=True, timeout=timeout, cwd=cwd)


def one_line_error(*args: str, cwd: Path | None = None) -> str:
    result = run_cli(*args, cwd=cwd, timeout=60)
    assert result.returncode == 2, (args, result.stdout, result.stderr)
    assert "Traceback" not in result.stderr
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1, (args, result.stderr)
    return lines[0]


def messages(path: Path, topic: str) -> list:
    with AnyReader([path], default_typestore=get_typestore(Stores.EMPTY)) as reader:
        conns = [c for c in reader.connections if c.topic == topic]
        if not conns:
            return []
        return [reader.deserialize(raw, c.msgtype) for c, _, raw in reader.messages(connections=conns)]


# --- 2. the flags users type pick the driver they mean ------------------------------------------------------
def test_steering_without_driver_means_the_constant_command(tmp_path):
    result = run_cli(
        "run",
        "--world",
        "empty",
        "--speed",
        "1.0",
        "--steering",
        "0.2",
        "--duration",
        "2",
        "--out",
        str(tmp_path),
        *QUIET,
    )
    assert result.returncode == 0, result.stderr
    assert "driver constant" in result.stdout
    commands = messages(tmp_path / "run.mcap", NAVIGATION)
    assert len(commands) == 40  # 20 Hz for 2 s
    assert {(c.drive.speed, c.drive.steering_angle) for c in commands} == {(1.0, np.float32(0.2))}
    odom = messages(tmp_path / "run.mcap", "/vesc/odom")
    q = odom[-1].pose.pose.orientation
    yaw = 2 * math.atan2(q.z, q.w)
    assert yaw > 0.3  # it turned left, as a 0.2 rad steer does (wall-follow would not have been told to)


def test_speed_zero_stands_still_with_the_constant_driver(tmp_path):
    for extra in ([], ["--driver", "constant"]):
        result = run_cli(
            "run",
            "--world",
            "empty",
            "--speed",
            "0",
            "--duration",
            "2",
            "--out",
            str(tmp_path),
            "--overwrite",
            *QUIET,
            *extra,
        )  # the second run replaces the first's run.mcap
        assert result.returncode == 0, result.stderr
        assert "driver constant" in result.stdout
        odom = messages(tmp_path / "run.mcap", "/vesc/odom")
        position = odom[-1].pose.pose.position
        assert math.hypot(position.x, position.y) < 1e-3


def test_an_option_for_another_driver_is_an_error_naming_both():
    line = one_line_error("run", "--driver", "constant", "--side", "right")
    assert "--side" in line and "constant" in line and "wall-follow" in line
    line = one_line_error("run", "--driver", "wall-follow", "--steering", "0.1")
    assert "--steering" in line and "wall-follow" in line
    line = one_line_error(
        "run", "--rate", "5", "--distance", "1.0"
    )  # --rate picks constant; --distance is wall-follow's
    assert "--distance" in line and "constant" in line
    line = one_line_error("run", "--driver", "pure-pursuit", "--rate", "10")
    assert "--rate" in line and "pure-pursuit" in line
    assert "speed" in one_line_error("run", "--driver", "wall-follow", "--speed", "0", "--world", "empty")


def test_no_options_still_run_wall_follow(tmp_path):
    result = run_cli("run", "--world", "empty", "--duration", "0.5", "--out", str(tmp_path), *QUIET)
    assert result.returncode == 0, result.stderr
    assert "driver wall-follow" in result.stdout


def test_seed_physics_and_profile_reach_the_simulator(tmp_path):
    result = run_cli(
        "run",
        "--world",
        "empty",
        "--driver",
        "constant",
        "--duration",
        "0.5",
        "--seed",
        "5",
        "--physics",
        "gazebo",
        "--profile",
        "mit-2017",
        "--no-record",
        *QUIET,
        cwd=tmp_path,
    )
    assert result.returncode == 0, result.stderr
    assert "profile mit-2017, physics gazebo (step 1 ms), seed 5" in result.stdout


def test_run_help_shows_the_defaults_of_its_driver_options():
    text = " ".join(run_cli("run", "--help").stdout.split())
    wall_follow = yaml.safe_load(WALL_FOLLOW_YAML.read_text())
    assert f"metres to keep from the wall (default {wall_follow['distance']:g})" in text
    assert f"top speed of wall-follow (default {wall_follow['speed']:g})" in text
    assert "the constant command (default 1;" in text
    assert "Hz of the constant command (default 20;" in text


# --- 3. a NaN command is refused where it enters ---------------------------------------------------------------
class GoesNaN:
    """A driver that publishes 1 m/s at 20 Hz, and NaN speeds from `after` seconds on."""

    def __init__(self, sim: Simulator, after: float, field: str = "speed") -> None:
        self.sim, self.after, self.field = sim, after, field
        sim.scheduler.every(20.0, self.publish, "goes_nan")

    def publish(self, now_ns: int) -> None:
        drive = AckermannDrive(speed=1.0)
        if now_ns * 1e-9 >= self.after:
            setattr(drive, self.field, float("nan"))
        self.sim.publish(NAVIGATION, AckermannDriveStamped(Header.at(now_ns, "base_link"), drive))


@pytest.mark.parametrize("field", ["speed", "steering_angle", "acceleration"])
def test_a_driver_that_goes_nan_leaves_the_car_stopped_within_half_a_second(caplog, field):
    sim = Simulator(world="empty", camera=False, lidar=False)
    log = Log(sim, "/vesc/odom", "/vesc/low_level/ackermann_cmd_mux/output", HIGH_ACTIVE)
    GoesNaN(sim, after=1.0, field=field)
    with caplog.at_level(logging.WARNING, logger="racecar_sim"):
        sim.run_until(3.0)
    moving = [o for o in log["/vesc/odom"] if o.header.stamp.to_ns() <= 1_000_000_000]
    assert ground_speed(moving[-1]) > 0.8
    after = [o for o in log["/vesc/odom"] if o.header.stamp.to_ns() >= 1_500_000_000]
    assert after and all(ground_speed(o) < 0.05 for o in after)
    outputs = log["/vesc/low_level/ackermann_cmd_mux/output"]
    assert all(math.isfinite(m.drive.speed) and math.isfinite(m.drive.steering_angle) for m in outputs)
    # the NaN stream does not keep Navigation 0 in control: the 0.2 s timeout runs out and Default takes over
    assert [m.data for m in log[HIGH_ACTIVE]][-1] == "Default"
    named = [r.getMessage() for r in caplog.records if NAVIGATION in r.getMessage()]
    assert len(named) == 1 and "not a finite number" in named[0]  # 40 NaN messages in 2 s: one warning per 5 s


def test_commands_in_numpy_numbers_drive_the_car():
    """A policy's np.float32 output is a number like any other (only NaN and infinity are refused)."""
    sim = Simulator(world="empty", camera=False, lidar=False)
    log = Log(sim, "/vesc/odom")

    def drive(now_ns: int) -> None:
        drive = AckermannDrive(speed=np.float32(1.0), steering_angle=np.float64(0.0))
        sim.publish(NAVIGATION, AckermannDriveStamped(Header.at(now_ns, "base_link"), drive))

    sim.scheduler.every(20.0, drive, "numpy_driver")
    sim.run_until(2.0)
    assert log["/vesc/odom"][-1].pose.pose.position.x > 1.5


def test_a_nan_controller_command_is_ignored_and_the_last_one_holds(caplog):
    sim = Simulator(world="empty", camera=False, lidar=False)
    log = Log(sim, "/racecar/joint_states")
    name = "left_steering_hinge_position_controller"
    topic = f"/racecar/{name}/command"
    sim.run_until(1.0)
    sim.publish(topic, Float64(0.3))
    with caplog.at_level(logging.WARNING, logger="racecar_sim"):
        for bad in [float("nan"), float("inf"), -float("inf")] * 20:
            sim.publish(topic, Float64(bad))
    assert sim.data.actuator(name).ctrl[0] == pytest.approx(0.3)  # the last finite command holds
    sim.run_until(1.1)  # before the next 6 Hz zero command
    state = log["/racecar/joint_states"][-1]
    assert np.isfinite(state.position).all() and np.isfinite(state.velocity).all()
    assert state.position[list(state.name).index("left_steering_hinge_joint")] > 0.02  # turning toward 0.3
    named = [r for r in caplog.records if topic in r.getMessage()]
    assert len(named) == 1  # 60 bad commands, one throttled warning


# --- 4. configuration is checked where it is read; a diverging physics stops the run --------------------------
def write_controllers(tmp_path: Path, gain: object) -> Path:
    data = yaml.safe_load(CONTROLLERS.read_text())
    data["racecar"]["left_rear_wheel_velocity_controller"]["pid"]["p"] = gain
    path = tmp_path / "racecar_control.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


@pytest.mark.parametrize("gain", [float("nan"), float("inf"), -1.0, "fast"])
def test_bad_pid_gains_name_the_file_and_the_field(tmp_path, gain):
    path = write_controllers(tmp_path, gain)
    robot = load_robot()
    with pytest.raises(ConfigError) as err:
        load_controller_config(path, robot)
    assert str(path) in str(err.value) and "left_rear_wheel_velocity_controller/pid/p" in str(err.value)
    with pytest.raises(ConfigError):
        Simulator(world="empty", camera=False, lidar=False, controllers=path)


def test_a_gain_written_as_1e3_is_read_as_the_number_ros_means(tmp_path):
    path = write_controllers(tmp_path, 1.0)
    path.write_text(path.read_text().replace("p: 1.0", "p: 1e3", 1))  # PyYAML reads 1e3 as a string
    config = load_controller_config(path, load_robot())
    assert config.controller("left_rear_wheel_joint").gains.p == 1000.0


@pytest.mark.parametrize("seed", [-1, 1.5, "abc", True, None])
def test_bad_seeds_are_refused_at_once(seed):
    with pytest.raises(ConfigError, match="seed"):
        Simulator(world="empty", camera=False, lidar=False, seed=seed)


def test_unknown_odometry_mode_is_a_config_error():
    with pytest.raises(ConfigError, match="nosuch.*original, ros"):
        Simulator(world="empty", camera=False, odometry="nosuch")


def test_mux_and_table_files_reject_non_finite_values(tmp_path):
    mux = tmp_path / "low_level_mux.yaml"
    mux.write_text("subscribers:\n  - {name: Teleoperation, topic: input/teleop, timeout: .nan, priority: 10}\n")
    with pytest.raises(ConfigError, match=r"low_level_mux.yaml.*Teleoperation.*timeout"):
        load_mux_inputs(mux)
    mux.write_text("subscribers:\n  - {name: Teleoperation, topic: input/teleop, timeout: 0.2, priority: high}\n")
    with pytest.raises(ConfigError, match="priority"):
        load_mux_inputs(mux)
    presets = tmp_path / "presets.yaml"
    presets.write_text(
        "bad:\n  timestep: .nan\n  integrator: implicitfast\n  solver: newton\n  iterations: 50\n"
        "  cone: pyramidal\n  contact_timeconst: 0.005\n"
    )
    with pytest.raises(ConfigError, match=r"presets.yaml: physics preset 'bad': timestep"):
        table_entry(presets, "bad", PhysicsPreset, "physics preset")


DIVERGING_WORLD = """<?xml version="1.0"?>
<sdf version="1.6"><world name="heavy">
  <physics type="ode"><max_step_size>0.0025</max_step_size><gravity>0 0 -1e12</gravity></physics>
  <model name="ground"><static>true</static><link name="link">
    <collision name="c"><geometry><plane><normal>0 0 1</normal><size>50 50</size></plane></geometry></collision>
    <visual name="v"><geometry><plane><normal>0 0 1</normal><size>50 50</size></plane></geometry>
      <material><ambient>0.5 0.5 0.5 1</ambient><diffuse>0.5 0.5 0.5 1</diffuse></material></visual>
  </link></model>
</world></sdf>
"""


def test_diverging_physics_stops_the_run_and_never_publishes_nan():
    sim = Simulator(world="empty", camera=False, lidar=False)
    log = Log(sim, "/vesc/odom", "/racecar/joint_states", "/tf")
    ConstantCommand(sim.bus, sim.scheduler, 1.0, 0.1)
    base = sim.model.body("base_link").id

    def blow_up(now_ns: int) -> None:  # from 0.5 s, a force no physics survives: the next steps diverge
        sim.data.xfrc_applied[base, 2] = 1e30

    sim.scheduler.at(500_000_000, blow_up, "blow_up")
    with pytest.raises(PhysicsError, match=r"diverged before t = 0\.5"):
        sim.run_until(2.0)
    with pytest.raises(PhysicsError):  # it stays stopped
        sim.run_until(3.0)
    odom = log["/vesc/odom"]
    assert len(odom) == 10 and odom[-1].header.stamp.to_ns() == 500_000_000  # 20 Hz up to the last good state
    for o in odom:
        p, v = o.pose.pose.position, o.twist.twist.linear
        assert all(math.isfinite(x) for x in (p.x, p.y, p.z, v.x, v.y, v.z))
    assert all(np.isfinite(j.position).all() and np.isfinite(j.velocity).all() for j in log["/racecar/joint_states"])
    assert max(t.transforms[0].header.stamp.to_ns() for t in log["/tf"]) <= 500_000_000


def test_diverging_physics_on_the_cli_is_one_line_and_the_recording_is_closed(tmp_path):
    world = tmp_path / "heavy.world"
    world.write_text(DIVERGING_WORLD)
    record = tmp_path / "run.mcap"
    result = run_cli(
        "run",
        "--world",
        str(world),
        "--driver",
        "constant",
        "--duration",
        "2",
        "--no-lidar",
        "--record",
        str(record),
        "--out",
        str(tmp_path / "out"),
        *QUIET,
    )
    assert result.returncode == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and "diverged" in lines[0] and "Traceback" not in result.stderr, result.stderr
    # a complete file: rosbags reads it (it needs the summary and the footer)
    assert len(messages(record, "/tf_static")) == 1
    for odom in messages(record, "/vesc/odom"):
        assert math.isfinite(odom.pose.pose.position.z)


# --- 5. CLI input that used to end in a traceback --------------------------------------------------------------
def test_cli_bad_input_is_one_line_and_exit_2(tmp_path):
    a_file = tmp_path / "a_file"
    a_file.write_text("not a folder")
    cases = [
        (["run", "--seed", "-1"], "--seed"),
        (["run", "--seed", "1.5"], "--seed"),
        (["run", "--seed", "abc"], "--seed"),
        (["teleop", "--seed", "-1"], "--seed"),
        (["run", "--out", str(a_file / "sub")], "not a folder"),
        (["run", "--record", str(a_file / "x.mcap")], "not a folder"),
        (["run", "--record", str(tmp_path)], "is a folder"),
        (["teleop", "--viewer", "--record", str(a_file / "x.mcap")], "not a folder"),
        (["bench", "--repeat", "0"], "--repeat"),
        (["run", "--world", "empty", "--driver", "constant", "--rate", "1e9", "--no-camera"], "--rate"),
    ]
    for args, needle in cases:
        assert needle in one_line_error(*args, cwd=tmp_path), args
    assert not (tmp_path / "runs").exists()  # nothing was created by the refused runs


def test_progress_bar_ends_at_its_total_without_tqdm_warnings(tmp_path):
    pexpect = pytest.importorskip("pexpect")
    # 5.001 s is not a whole number of 2.5 ms steps: the sim ends past the bar's total, which tqdm used to
    # clamp with a warning and show as a negative remaining time
    child = pexpect.spawn(
        sys.executable,
        [
            "-m",
            "racecar_sim",
            "run",
            "--world",
            "empty",
            "--driver",
            "constant",
            "--duration",
            "5.001",
            "--no-record",
            *QUIET,
        ],
        cwd=str(tmp_path),
        timeout=120,
        encoding="utf-8",
        dimensions=(24, 160),
    )
    child.expect(pexpect.EOF)
    child.close()
    assert child.exitstatus == 0, child.before
    assert "clamping frac" not in child.before
    assert "<-" not in child.before
    assert "5.0/5.0 sim s" in child.before


@pytest.mark.parametrize(
    "field, value", [("speed", float("nan")), ("repeat_rate", 0.0), ("bindings", {"w": [1, math.inf]})]
)
def test_bad_teleop_config_names_the_file_and_field(tmp_path, field, value):
    from racecar_sim.control.teleop import DEFAULTS, load_teleop_config

    data = yaml.safe_load(DEFAULTS.read_text())
    data[field] = value
    path = tmp_path / "keyboard_teleop.yaml"
    path.write_text(yaml.safe_dump(data))
    with pytest.raises(ConfigError) as err:
        load_teleop_config(path)
    assert str(path) in str(err.value) and field in str(err.value)
