"""Issue 21's hard edges of the Python API and its security (each a probe's reproduction that once failed).

A message of the wrong type on a command topic, an env's malformed action or spawn option, an off-world spawn at
sim.reset(), a launch file's $(eval) that escapes to a shell, and the roscore racecar-sim starts listening on every
interface: each is one line (a RacecarSimError or one throttled warning) naming what was given, and changes nothing.
"""

from __future__ import annotations

import logging
import math
import os
import socket
import subprocess
import sys
import time
import xmlrpc.client
from pathlib import Path
from xml.sax.saxutils import quoteattr

import numpy as np
import pytest

from racecar_sim.core.errors import CommandError, ConfigError, WorldError
from racecar_sim.envs.batch import DriveBatch
from racecar_sim.envs.drive import DriveEnv
from racecar_sim.envs.race import RaceEnv
from racecar_sim.launch.errors import SubstitutionError
from racecar_sim.launch.substitution import Context, resolve
from racecar_sim.msgs import AckermannDrive, AckermannDriveStamped, Float64, String
from racecar_sim.runtime import Simulator
from racecar_sim.runtime.car import Car
from racecar_sim.worlds import Spawn

NAVIGATION = "/vesc/ackermann_cmd_mux/input/navigation"  # the relay to the high-level mux's nav_0


# --- 1. a message of the wrong type on a command topic -------------------------------------------------------------
@pytest.fixture(scope="module")
def sim() -> Simulator:
    return Simulator(world="empty", camera=False, lidar=False)


@pytest.mark.parametrize(
    ("topic", "expected"),
    [
        (NAVIGATION, "ackermann_msgs/AckermannDriveStamped"),  # a relay
        ("/vesc/high_level/ackermann_cmd_mux/input/nav_1", "ackermann_msgs/AckermannDriveStamped"),  # a mux input
        ("/vesc/low_level/ackermann_cmd_mux/input/safety", "ackermann_msgs/AckermannDriveStamped"),
        ("/vesc/low_level/ackermann_cmd_mux/output", "ackermann_msgs/AckermannDriveStamped"),  # servo_commands' input
        ("/racecar/left_rear_wheel_velocity_controller/command", "std_msgs/Float64"),
        ("/gazebo/set_model_state", "gazebo_msgs/ModelState"),
    ],
)
def test_a_message_of_the_wrong_type_on_a_command_topic_is_dropped_with_one_warning(sim, caplog, topic, expected):
    sim.reset()
    qpos = sim.data.qpos.copy()
    heard, tapped = [], []  # a user's own subscriber, and a recorder or bridge: neither is handed the String
    sub = sim.subscribe(topic, heard.append)
    remove_tap = sim.bus.tap(lambda name, msg: tapped.append(msg) if name == topic else None)
    with caplog.at_level(logging.WARNING, logger="racecar_sim"):
        for _ in range(10):  # 10 in 0.5 s of sim time: one warning (at most one per 5 s)
            sim.publish(topic, String("go"))
            sim.run_for(0.05)
    sub.unsubscribe()
    remove_tap()
    named = [r.getMessage() for r in caplog.records if topic in r.getMessage()]
    assert named == [f"{topic}: ignored a std_msgs/String message (the topic takes {expected})"]
    assert not any(isinstance(msg, String) for msg in heard + tapped) and sim.bus.topics()[topic] is not String
    assert sim.car.chain.in_control() != "Safety" and np.allclose(sim.data.qpos[:2], qpos[:2], atol=1e-3)
    # the topic still takes its own type afterwards (the dropped message did not make it a String topic)
    sim.publish(NAVIGATION, AckermannDriveStamped(drive=AckermannDrive(speed=1.0)))
    sim.run_for(0.05)
    assert sim.car.chain.in_control() == "Navigation"


def test_a_wrong_type_refreshes_no_timeout(sim, caplog):
    teleop = "/vesc/ackermann_cmd_mux/input/teleop"
    sim.reset()
    sim.publish(teleop, AckermannDriveStamped(drive=AckermannDrive(speed=1.0)))
    sim.run_for(0.05)
    assert sim.car.chain.in_control() == "Teleoperation"
    with caplog.at_level(logging.WARNING, logger="racecar_sim"):
        for _ in range(10):  # a driver that goes on publishing, but the wrong type: the car stops as for silence
            sim.publish(teleop, Float64(1.0))
            sim.run_for(0.05)
    assert sim.car.chain.in_control() != "Teleoperation"
    assert sum(f"{teleop}: ignored a std_msgs/Float64" in r.getMessage() for r in caplog.records) == 1


# --- 2. an env's action of the wrong shape, or NaN --------------------------------------------------------------------
@pytest.fixture(scope="module")
def drive_env() -> DriveEnv:
    env = DriveEnv(world="empty")
    env.reset(seed=0)
    yield env
    env.close()


@pytest.mark.parametrize(
    ("action", "error", "words"),
    [
        (np.zeros(3), ConfigError, ["shape (3,) given", "Box(-1.0, 1.0, (2,), float32)", "takes shape (2,)"]),
        (np.zeros((1, 2)), ConfigError, ["shape (1, 2) given", "takes shape (2,)"]),
        ("go", ConfigError, ["action 'go' is not an array of numbers", "Box(-1.0, 1.0, (2,), float32)"]),
        ([math.nan, 0.0], CommandError, ["action [nan, 0.0] holds a NaN", "Box(-1.0, 1.0, (2,), float32)"]),
    ],
)
def test_drive_env_refuses_a_malformed_action_in_one_line(drive_env, action, error, words):
    before = drive_env.sim.time_ns
    with pytest.raises(error) as err:
        drive_env.step(action)
    message = str(err.value)
    assert message.startswith("DriveEnv.step: ") and "\n" not in message
    for word in words:
        assert word in message, message
    assert drive_env.sim.time_ns == before  # refused before anything ran
    drive_env.step(np.array([0.5, 0.0], np.float32))  # and the env goes on
    drive_env.step([math.inf, 0.0])  # an infinity is clipped to the box, as any value outside it


def test_race_env_and_batch_refuse_a_malformed_action(tmp_path):
    env = RaceEnv(num_cars=2, world="empty", sensor_noise=False)
    try:
        env.reset(seed=0)
        with pytest.raises(ConfigError, match=r"^RaceEnv.step: car2: action of shape \(3,\) given"):
            env.step({"car1": np.zeros(2), "car2": np.zeros(3)})
        with pytest.raises(CommandError, match=r"^RaceEnv.step: car1: action \[nan, nan\] holds a NaN"):
            env.step({"car1": [math.nan, math.nan]})
        with pytest.raises(ConfigError, match=r"no agent 'car3' \(agents: car1, car2\)"):
            env.step({"car3": np.zeros(2)})
        assert env.sim.time_ns == 0
        with pytest.raises(ConfigError, match=r"reset options spawn\[1\]=\(nan, 0.0, 0.0\): x must be a finite"):
            env.reset(options={"spawn": [(0.0, 0.0, 0.0), (math.nan, 0.0, 0.0)]})
    finally:
        env.close()
    batch = DriveBatch(2, world="empty", lidar=False, seeds=0)
    try:
        batch.reset()
        with pytest.raises(
            ConfigError,
            match=r"DriveBatch.step \(2 worlds\): action of shape \(2,\) given; it takes "
            r"shape \(2, 2\), a row per world",
        ):
            batch.step(np.zeros(2))
        with pytest.raises(CommandError, match=r"DriveBatch.step \(2 worlds\): action .* holds a NaN"):
            batch.step(np.array([[0.0, 0.0], [math.nan, 0.0]]))
    finally:
        batch.close()


# --- 3. an env's spawn option ---------------------------------------------------------------------------------------
def test_drive_env_reset_refuses_a_nan_or_off_world_spawn(drive_env):
    with pytest.raises(ConfigError) as err:
        drive_env.reset(options={"spawn": (math.nan, 0, 0)})
    assert str(err.value) == "reset options spawn=(nan, 0, 0): x must be a finite number, got nan"
    with pytest.raises(WorldError, match=r"spawn pose \(100, 100, 0.05, 0\) has no ground under it"):
        drive_env.reset(options={"spawn": (100, 100, 0)})
    drive_env.reset(options={"spawn": (1.0, 0.0, 0.0)})
    assert drive_env.agent.pose()[0] == pytest.approx(1.0, abs=1e-6)


# --- 4. sim.reset(spawn=...) ----------------------------------------------------------------------------------------
def test_sim_reset_checks_the_spawn_as_the_constructor_and_leaves_the_sim_as_it_was(sim):
    sim.reset()
    sim.publish(NAVIGATION, AckermannDriveStamped(drive=AckermannDrive(speed=1.0)))
    sim.run_for(0.3)
    qpos, qvel, now, seed = sim.data.qpos.copy(), sim.data.qvel.copy(), sim.time_ns, sim.seed
    cases = [
        (Spawn(100, 100, 0.05, 0), WorldError, "spawn pose (100, 100, 0.05, 0) has no ground under it"),
        (Spawn(0, 0, -1.0, 0), WorldError, "is below the ground"),
        (Spawn(math.nan, 0, 0.05, 0), ConfigError, "reset spawn for racecar: x must be a finite number, got nan"),
        ({"car9": Spawn()}, ConfigError, "reset spawn: no car named 'car9'"),
    ]
    for spawn, error, words in cases:
        with pytest.raises(error) as err:
            sim.reset(seed=seed + 1, spawn=spawn)
        assert words in str(err.value) and "\n" not in str(err.value)
        assert np.array_equal(sim.data.qpos, qpos) and np.array_equal(sim.data.qvel, qvel)
        assert sim.time_ns == now and sim.seed == seed
    sim.run_for(0.3)  # the run goes on from where it was
    assert np.isfinite(sim.data.qpos).all() and sim.data.qpos[0] > qpos[0]


def test_sim_reset_refuses_a_car_put_onto_another():
    fleet = Simulator(
        world="empty",
        cars=[
            Car("car1", lidar=False, camera=False),
            Car("car2", spawn=Spawn(-1.5, 0, 0.05, 0), lidar=False, camera=False),
        ],
    )
    with pytest.raises(WorldError, match=r"car2.s spawn pose \(0.1, 0, 0.05, 0\) is .* car1/"):
        fleet.reset(spawn={"car2": Spawn(0.1, 0, 0.05, 0)})
    fleet.reset(spawn=[Spawn(0, 0, 0.05, 0), Spawn(-2.0, 0, 0.05, 0)])


def test_sim_reset_sees_a_maps_held_out_walls(tmp_path):
    from racecar_sim.physics.near_walls import WallBoxes
    from test_near_walls import speckled_room  # a map of many boxes: the walls near the cars are placed at a reset

    sim = Simulator(world=str(speckled_room(tmp_path)), camera=False, lidar=False)
    boxes = WallBoxes.of(sim.model)
    x, y = boxes.pos[np.argmax(boxes.half[:, 0] * boxes.half[:, 1]), :2]  # inside the biggest box, far from (0, 0)
    held = sim.near_walls.held.copy()
    with pytest.raises(WorldError, match="is inside an obstacle"):
        sim.reset(spawn=Spawn(float(x), float(y), 0.05, 0.0))
    assert np.array_equal(sim.near_walls.held, held)  # the walls near the car where it stands, as before
    sim.reset(spawn=Spawn(0.5, 0.0, 0.05, 0.0))
    sim.run_for(0.5)
    assert np.isfinite(sim.data.qpos).all()


# --- 5. $(eval) runs no code ----------------------------------------------------------------------------------------
def _exploits(marker: Path) -> dict[str, str]:
    """The probe's escapes from eval()'s restricted builtins, with no double underscore: a running generator's
    frame leads back to the module that called eval(), its globals and its real builtins."""
    frame = "[[(g := (g.gi_frame.f_back.f_back.{} for _ in [0])) for _ in [0]], list(g)][1][0]"
    return {
        "shell": frame.format("f_globals") + f"['os'].system('touch {marker}')",
        "builtins": frame.format("f_builtins") + f"['open']('{marker}', 'w')",
    }


@pytest.mark.parametrize("kind", ["shell", "builtins"])
def test_a_launch_file_eval_cannot_escape_to_a_shell(tmp_path, kind):
    marker = tmp_path / "marker"
    path = tmp_path / "evil.launch"
    path.write_text(
        f"<launch>\n  <arg name='a' default='1'/>\n"
        f"  <param name='p' value={quoteattr('$(eval ' + _exploits(marker)[kind] + ')')}/>\n</launch>\n"
    )
    result = subprocess.run(
        [sys.executable, "-m", "racecar_sim", "launch", str(path), "--duration", "0.1", "--no-camera", "--no-lidar"],
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    assert not marker.exists(), "the launch file ran code"
    assert result.returncode == 2, result.stderr
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f'racecar-sim: error: {path}:3: <param name="p">: $(eval ')
    assert "is not allowed; $(eval) takes expressions only" in lines[0]


@pytest.mark.parametrize(
    ("expression", "refused"),
    [
        ("'abc'.upper()", "attribute access `'abc'.upper`"),
        ("(x for x in [1])", "a generator"),
        ("[x for x in [1]]", "a comprehension"),
        ("(lambda: 1)()", "a lambda"),
        ("(y := 1)", "an assignment (:=)"),
        ("f'{1}'", "an f-string"),
        ("[1][0](2)", "[1][0] is not a function $(eval) may call"),
    ],
)
def test_eval_refuses_everything_but_expressions(expression, refused):
    with pytest.raises(SubstitutionError) as err:
        resolve(f"$(eval {expression})", Context({}, Path("/x.launch")))
    assert refused in str(err.value) and "$(eval) takes expressions only" in str(err.value)


def test_eval_still_computes_what_launch_files_compute():
    c = Context({"x": "1.5", "n": "3", "flag": "true", "name": "car"}, Path("/x.launch"))
    assert resolve("$(eval [1, 2, 3][n - 2:])", c) == "[2, 3]"
    assert resolve("$(eval {'a': x}['a'] * 2 if 1 < n <= 3 and flag else 0)", c) == "3.0"
    assert resolve("$(eval '%s_%d' % (name, n))", c) == "car_3"
    assert resolve("$(eval int(float(arg('x')) * 4) // 3)", c) == "2"
    assert resolve("$(eval -x ** 2)", c) == "-2.25"
    with pytest.raises(SubstitutionError, match=r"failed: ValueError: .* is too large"):
        resolve("$(eval 9 ** 9 ** 9)", c)


# --- 6. what racecar-sim starts for --ros listens on 127.0.0.1 only ------------------------------------------------
def _descendants(pid: int) -> list[int]:
    children: dict[int, list[int]] = {}
    for entry in os.listdir("/proc"):
        if entry.isdigit():
            try:
                with open(f"/proc/{entry}/stat") as f:
                    parent = int(f.read().rsplit(")", 1)[1].split()[1])
            except (OSError, ValueError, IndexError):
                continue
            children.setdefault(parent, []).append(int(entry))
    found, todo = [], list(children.get(pid, []))
    while todo:
        child = todo.pop()
        found.append(child)
        todo.extend(children.get(child, []))
    return found


def _listening(pids: list[int]) -> list[tuple[int, str, int]]:
    """(pid, address, port) of every listening TCP socket of `pids`, from /proc/net/tcp{,6} and /proc/<pid>/fd."""
    owner = {}
    for pid in pids:
        try:
            for fd in os.listdir(f"/proc/{pid}/fd"):
                link = os.readlink(f"/proc/{pid}/fd/{fd}")
                if link.startswith("socket:["):
                    owner[link[8:-1]] = pid
        except OSError:
            continue
    found = []
    for table, family in (("tcp", socket.AF_INET), ("tcp6", socket.AF_INET6)):
        with open(f"/proc/net/{table}") as f:
            for line in list(f)[1:]:
                fields = line.split()
                if fields[3] != "0A" or fields[9] not in owner:  # 0A: LISTEN
                    continue
                address, port = fields[1].split(":")
                raw = bytes.fromhex(address)
                raw = b"".join(raw[i : i + 4][::-1] for i in range(0, len(raw), 4))  # host-order 32-bit words
                found.append((owner[fields[9]], socket.inet_ntop(family, raw), int(port, 16)))
    return found


ROS = Path("/usr/bin/roscore").exists() and Path("/proc/net/tcp").exists()


@pytest.mark.skipif(not ROS, reason="ROS 1 is not installed (apt-get install ros-core python3-rospy ...)")
def test_the_roscore_and_bridge_of_ros_listen_on_loopback_only(monkeypatch):
    from racecar_sim.bridges.ros1 import RosBridge, ros_available

    if not ros_available():
        pytest.skip("rospy is not installed")
    for name in ("ROS_MASTER_URI", "ROS_IP", "ROS_HOSTNAME"):  # the user asks for nothing: racecar-sim starts it all
        monkeypatch.delenv(name, raising=False)
    sim = Simulator(world="empty", camera=False, lidar=False)
    with RosBridge(sim) as bridge:  # started as `run --ros` starts it
        master = xmlrpc.client.ServerProxy(bridge.master_uri)
        deadline = time.monotonic() + 60
        while True:  # rosout up and serving (its XML-RPC API was the socket on 0.0.0.0)
            code, _, uri = master.lookupNode("/test", "/rosout")
            sockets = _listening(_descendants(os.getpid()))
            if code == 1 and int(uri.rstrip("/").rsplit(":", 1)[1]) in {port for _, _, port in sockets}:
                break
            assert time.monotonic() < deadline, "rosout never came up"
            time.sleep(0.2)
    # rosmaster, rosout's XML-RPC and TCPROS servers, the bridge's ROS side's two
    assert len(sockets) >= 5, sockets
    assert all(address in ("127.0.0.1", "::1") for _, address, _ in sockets), sockets
