"""The ROS 1 bridge made whole (issue 23): what a ROS node publishes passes through the sim's muxes and comes back out
to ROS on every output topic, so the original stack's own nodes drive the car; and the README's `--ros` commands work
as typed, with the run kept to the wall clock (and `--fast` running ahead of it).

tests/data/servo_commands.py is racecar_control's original node from mit-racecar/racecar_gazebo (its newest commit,
byte for byte): rospy, Float64 on /racecar/<controller>/command from the mux output it subscribes to, which
racecar_control.launch remaps onto /vesc/low_level/ackermann_cmd_mux/output. Every ROS process runs under the ROS
interpreter (/usr/bin/python3) with the environment `racecar-sim ros-env` gives, on a roscore of 127.0.0.1. The
tests with ROS are skipped only where ROS 1 is not installed; those of the pacing options run everywhere.
"""

from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
import time
import xmlrpc.client
from argparse import Namespace
from pathlib import Path

import numpy as np
import pytest

from racecar_sim.bridges.ros1 import RosBridge, message_path, ros_available, ros_python
from racecar_sim.bridges.ros1.environment import ros_environment
from racecar_sim.bridges.ros1.master import DEFAULT_PORT, DEFAULT_URI, Master, free_port
from racecar_sim.cli import live
from racecar_sim.core.errors import ConfigError
from racecar_sim.runtime import Simulator
from racecar_sim.runtime.car import Car, CarNodes

needs_ros = pytest.mark.skipif(
    not (Path("/usr/bin/roscore").exists() and ros_available()),
    reason="ROS 1 is not installed (apt-get install ros-core python3-rospy ...)",
)
CLI = [sys.executable, "-m", "racecar_sim"]
SERVO_COMMANDS = Path(__file__).parent / "data" / "servo_commands.py"
TELEOP = "/vesc/ackermann_cmd_mux/input/teleop"
MUX_OUTPUT = "/vesc/low_level/ackermann_cmd_mux/output"
REAR_WHEEL = "/racecar/left_rear_wheel_velocity_controller/command"
DRIVE = "ackermann_msgs/AckermannDriveStamped"


def test_a_bridge_paces_the_run_unless_fast():
    """--ros or --ros2 keep the run to the wall clock; --fast runs ahead; --realtime paces a run with no bridge."""
    assert not live.paced(Namespace(ros=False, realtime=False, fast=False))
    assert live.paced(Namespace(ros=True, realtime=False, fast=False))
    assert live.paced(Namespace(ros=False, ros2=True, realtime=False, fast=False))
    assert live.bridged(Namespace(ros2=True)) and not live.bridged(Namespace())
    assert not live.paced(Namespace(ros=True, ros2=True, realtime=False, fast=True))
    assert live.paced(Namespace(ros=False, realtime=True, fast=False))
    assert live.paced(Namespace(realtime=False, fast=False), default=True)  # launch without --duration
    assert not live.paced(Namespace(realtime=False, fast=True), default=True)
    with pytest.raises(ConfigError, match="--realtime and --fast"):
        live.paced(Namespace(ros=True, realtime=True, fast=True))


@pytest.mark.parametrize("command", [["run", "--duration", "0.1"], ["launch", "missing.launch"]])
def test_realtime_and_fast_together_is_one_line(tmp_path, command):
    done = subprocess.run(
        [*CLI, *command, "--realtime", "--fast"], cwd=tmp_path, capture_output=True, text=True, timeout=120
    )
    assert done.returncode == 2, done.stderr
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and "--realtime and --fast contradict each other" in lines[0], done.stderr
    assert not (tmp_path / "runs").exists()


@pytest.fixture(scope="module")
def master() -> Master:
    """A roscore on a free port of 127.0.0.1 for this module."""
    core = Master(None, ros_environment(None, None), port=None)
    yield core
    core.close()


@pytest.fixture
def ros_env(master: Master) -> dict[str, str]:
    """The environment of a user's ROS process, as `eval "$(racecar-sim ros-env)"` sets it."""
    return ros_environment(master.uri, message_path())


def start(command: list[str], env: dict[str, str], **options) -> subprocess.Popen:
    """A ROS process in its own session (stop() ends it and what it started)."""
    return subprocess.Popen(command, env=env, start_new_session=True, **options)


def stop(process: subprocess.Popen, sig: int = signal.SIGINT) -> None:
    if process.poll() is None:
        os.killpg(process.pid, sig)
        try:
            process.wait(15)
        except subprocess.TimeoutExpired:
            os.killpg(process.pid, signal.SIGKILL)
            process.wait()


def registered(master: xmlrpc.client.ServerProxy, service: str) -> bool:
    """Whether a master answers and has `service` (False while the run's own roscore is not up yet)."""
    try:
        return master.lookupService("/test", service)[0] == 1
    except OSError:
        return False


def paced(sim: Simulator, bridge: RosBridge, seconds: float, until=lambda: False) -> None:
    """Run the sim at the wall clock's pace (as `run --ros` does) for `seconds` of wall time or until `until()`."""
    start_wall, start_sim = time.monotonic(), sim.time
    while time.monotonic() - start_wall < seconds and not until():
        sim.run_for(0.02)
        bridge.spin_once()
        ahead = (sim.time - start_sim) - (time.monotonic() - start_wall)
        if ahead > 0:
            time.sleep(ahead)


@needs_ros
def test_original_servo_commands_node_drives_the_car_at_half_a_rostopic_command(master, ros_env):
    """servo_commands.py as a ROS node, the sim's own servo left out, `rostopic pub` on the teleop mux input: the
    mux output reaches the node, its wheel commands reach the controllers, and the car drives at half the command
    (mit-2017's arithmetic: every wheel speed/0.1 rad/s on 0.05 m wheels)."""
    sim = Simulator(world="empty", cars=[Car("", camera=False, nodes=CarNodes(servo_input=None))])
    assert sim.car.servo is None
    wheel, odom = [], []
    sim.subscribe(REAR_WHEEL, wheel.append)
    sim.subscribe("/vesc/odom", odom.append)
    bridge = RosBridge(sim, master.uri)
    bridge.start()
    servo = start([ros_python(), str(SERVO_COMMANDS), f"/racecar/ackermann_cmd_mux/output:={MUX_OUTPUT}"], ros_env)
    pub = start(["rostopic", "pub", "-r", "20", TELEOP, DRIVE, "{drive: {speed: 1.0, steering_angle: 0.0}}"], ros_env)
    try:
        # rostopic, the bridge and the node connect (the 6 Hz zero command comes through first)
        paced(sim, bridge, 60.0, until=lambda: any(msg.data > 0 for msg in wheel))
        assert wheel and wheel[-1].data > 0, "no wheel command for the teleop speed from servo_commands.py in 60 s"
        first = len(wheel) - 1
        paced(sim, bridge, 4.0)
    finally:
        stop(pub)
        stop(servo)
        bridge.close()
        sim.close()
    driven = [msg.data for msg in wheel[first:]]
    assert max(driven) == pytest.approx(10.0)  # 1.0 m/s / 0.1
    assert driven.count(max(driven)) >= 0.9 * len(driven)  # the teleop input kept control (0.2 s timeout)
    recent = [o for o in odom if o.header.stamp.sec + o.header.stamp.nanosec * 1e-9 > sim.time - 1.5]
    speeds = [np.hypot(o.twist.twist.linear.x, o.twist.twist.linear.y) for o in recent]
    assert np.mean(speeds) == pytest.approx(0.5, abs=0.06), speeds


@needs_ros
def test_rostopic_hz_sees_the_mux_output_while_a_ros_node_drives(master, ros_env):
    """While `rostopic pub` drives through the teleop input, the low-level mux output (what the command becomes
    in the sim) reaches ROS at the input's rate, carrying the command; the input itself is not echoed back."""
    sim = Simulator(world="empty", camera=False)
    bridge = RosBridge(sim, master.uri)
    bridge.start()
    pub = start(["rostopic", "pub", "-r", "20", TELEOP, DRIVE, "{drive: {speed: 1.0, steering_angle: 0.2}}"], ros_env)
    hz = echo = None
    try:
        paced(sim, bridge, 60.0, until=lambda: bridge.received > 0)
        assert bridge.received, "the teleop command never reached the sim"
        hz = start(["rostopic", "hz", MUX_OUTPUT], ros_env, stdout=subprocess.PIPE, text=True)
        echo = start(["rostopic", "echo", "-n", "3", MUX_OUTPUT + "/drive"], ros_env, stdout=subprocess.PIPE, text=True)
        paced(sim, bridge, 6.0)
        sent_back = bridge._out[TELEOP].seq if TELEOP in bridge._out else 0
    finally:
        for process in (hz, echo, pub):
            if process is not None:
                stop(process)
        bridge.close()
        sim.close()
    hz_out, echo_out = hz.communicate()[0], echo.communicate()[0]
    rates = [float(r) for r in re.findall(r"average rate: ([0-9.]+)", hz_out)]
    assert rates, f"rostopic hz saw nothing: {hz_out!r}"
    assert "no new messages" not in hz_out
    assert 15.0 < rates[-1] < 30.0, hz_out  # 20 Hz of commands, in sim time kept to the wall clock
    speeds = [float(v) for v in re.findall(r"\nspeed: (\S+)", "\n" + echo_out)]
    steering = [float(v) for v in re.findall(r"\nsteering_angle: (\S+)", "\n" + echo_out)]
    assert speeds == [1.0] * 3 and steering == pytest.approx([0.2] * 3), echo_out  # float32 on the wire
    assert sent_back == 0  # what ROS published on the teleop input does not come back to it


# The commands test_readme_ros_commands_work_as_typed runs, as docs/ros1.md types them (a `\` continues a line).
ROS1_COMMANDS = [
    "racecar-sim run --ros --world tunnel --no-camera &",
    'eval "$(racecar-sim ros-env)"',
    f"rostopic pub -r 20 {TELEOP} {DRIVE} '{{drive: {{speed: 1.0, steering_angle: 0.2}}}}'",
    "rosservice call /gazebo/get_model_state '{model_name: racecar}'",
]


def test_the_docs_ros_commands_are_the_ones_tested():
    """docs/ros1.md's `--ros` block (linked from the README's recipes) holds the commands the test below types."""
    page = (Path(__file__).parents[1] / "docs" / "ros1.md").read_text()
    block = page.split("racecar-sim run --ros --world tunnel", 1)[0].rsplit("```sh\n", 1)[1]
    block += "racecar-sim run --ros --world tunnel" + page.split("racecar-sim run --ros --world tunnel", 1)[1]
    block = block.split("```", 1)[0].replace("\\\n", "")
    typed = [" ".join(line.split("  #", 1)[0].split()) for line in block.splitlines()]
    assert typed[-len(ROS1_COMMANDS) :] == ROS1_COMMANDS, typed


@needs_ros
def test_readme_ros_commands_work_as_typed(master, tmp_path):
    """The README's sequence, in a shell as a user types it: `racecar-sim run --ros --world tunnel --no-camera &`,
    `eval "$(racecar-sim ros-env)"`, `rostopic pub -r 20 ...`, `rosservice call /gazebo/get_model_state ...`. The run
    is still there when the commands come (it keeps to the wall clock until stopped), the command drives the car
    through the muxes, and the service answers with a pose that moves as sim time passes with the wall clock.

    As a new user has it: no ROS_MASTER_URI, so the run starts its roscore on 127.0.0.1:11311 and ros-env points
    there; where that port is taken (another ROS on this machine), a user's own running roscore instead."""
    env = dict(os.environ)
    env.pop("ROS_MASTER_URI", None)
    uri = DEFAULT_URI
    if free_port(DEFAULT_PORT) != DEFAULT_PORT:
        env["ROS_MASTER_URI"] = uri = master.uri
    env["PATH"] = os.pathsep.join((str(Path(sys.executable).parent), env.get("PATH", "")))  # the venv, activated
    for name in ("ROS_IP", "ROS_HOSTNAME", "PYTHONPATH"):
        env.pop(name, None)

    def shell(line: str, **options) -> subprocess.Popen:
        return start(["bash", "-c", f'eval "$(racecar-sim ros-env)" && {line}'], env, cwd=tmp_path, **options)

    def get_model_state() -> tuple[float, float, float, str]:
        call = shell(ROS1_COMMANDS[3], stdout=subprocess.PIPE, text=True)
        out = call.communicate(timeout=60)[0]
        assert call.returncode == 0 and "success: True" in out, out
        x, y = (float(re.search(rf"\n\s+{axis}: (\S+)", out.split("position:")[1])[1]) for axis in "xy")
        stamp = out.split("stamp:")[1]
        # rostime prints nsecs right-aligned in 9 columns: "nsecs:  15000000" below 0.1 s
        secs, nsecs = (int(re.search(rf"{field}:\s+(\d+)", stamp)[1]) for field in ("secs", "nsecs"))
        return x, y, secs + nsecs * 1e-9, out

    out_file, err_file = tmp_path / "run.out", tmp_path / "run.err"
    with open(out_file, "w") as out, open(err_file, "w") as err:
        run = start(
            ROS1_COMMANDS[0].removesuffix(" &").split(),
            env,
            cwd=tmp_path,
            stdout=out,
            stderr=err,
        )
    pub = echo = None
    try:
        ros_master = xmlrpc.client.ServerProxy(uri)
        end = time.monotonic() + 120
        while not registered(ros_master, "/gazebo/get_model_state"):  # the user reads the bridge line
            assert run.poll() is None, err_file.read_text()[-3000:]
            assert time.monotonic() < end, "the run's services never registered"
            time.sleep(0.2)
        x0, y0, t0, _ = get_model_state()
        wall0 = time.monotonic()
        pub = shell(ROS1_COMMANDS[2])
        echo = shell(f"rostopic echo -n 40 {MUX_OUTPUT}/drive", stdout=subprocess.PIPE, text=True)
        echoed = echo.communicate(timeout=60)[0]
        time.sleep(2.0)
        x1, y1, t1, _ = get_model_state()
        wall1 = time.monotonic()
        alive = run.poll() is None
    finally:
        for process in (echo, pub):
            if process is not None:
                stop(process)
        stop(run, signal.SIGTERM)  # `kill %1`
    out, err = out_file.read_text(), err_file.read_text()
    assert alive, "the run was gone before the commands came"
    # the teleop command, through the muxes and back out to ROS (float32 on the wire), in control after the
    # wall-follow driver's commands (the navigation input, of lower priority)
    commands = [
        (float(speed), float(steering))
        for steering, speed in re.findall(r"steering_angle: (\S+)\nsteering_angle_velocity: \S+\nspeed: (\S+)", echoed)
    ]
    assert len(commands) == 40 and commands[-1] == (1.0, pytest.approx(0.2)), echoed
    assert np.hypot(x1 - x0, y1 - y0) > 0.5, (x0, y0, x1, y1)
    assert 0.5 < (t1 - t0) / (wall1 - wall0) < 1.3, (t0, t1, wall0, wall1)  # sim time kept to the wall clock
    assert run.returncode == 130, err[-3000:]  # stopped, files complete
    assert "running in real time until Ctrl-C" in err
    assert "wrote" in out and (tmp_path / "runs").is_dir()


@needs_ros
def test_run_ros_fast_runs_ahead_for_its_default_60_s(master, tmp_path):
    """`run --ros --fast`: the sim runs ahead of the wall clock, for run's usual 60 s of sim time."""
    env = dict(os.environ, ROS_MASTER_URI=master.uri)
    start_wall = time.monotonic()
    done = subprocess.run(
        [*CLI, "run", "--ros", "--fast", "--world", "empty", "--no-camera", "--driver", "constant", "--no-record"],
        cwd=tmp_path,
        env=env,
        capture_output=True,
        text=True,
        timeout=300,
    )
    wall = time.monotonic() - start_wall
    assert done.returncode == 0, done.stderr[-3000:]
    assert "sim time         60.00 s" in done.stdout
    assert wall < 50, f"60 s of sim time took {wall:.0f} s of wall time with --fast"
    assert "until Ctrl-C" not in done.stderr
