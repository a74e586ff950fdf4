"""`racecar-sim teleop` (keyboard_teleop.py): the node in-process, the terminal layer on a pty, the CLI through pexpect.

The CLI runs in real time, so its assertions come from the sim-time data it records, never from wall time.
"""

from __future__ import annotations

import itertools
import math
import os
import re
import signal
import subprocess
import sys
import termios
import time
from collections.abc import Iterator
from pathlib import Path

import pexpect
import pytest

from conftest import TELEOP, Log
from racecar_sim import Simulator
from racecar_sim.cli.terminal import RawTerminal, StopSignals
from racecar_sim.control.mux import IDLE_ZERO
from racecar_sim.control.teleop import KeyboardTeleop
from racecar_sim.drivers import NAVIGATION, ConstantCommand
from racecar_sim.msgs import AckermannDrive, AckermannDriveStamped, Header

LOW = "/vesc/low_level/ackermann_cmd_mux"
ACTIVE, OUTPUT = f"{LOW}/active", f"{LOW}/output"
CLI = f"{sys.executable} -m racecar_sim teleop --world empty --no-camera --no-lidar"
TIMEOUT = 60  # s of wall time for anything the CLI prints: a slow 2-core CI machine
NOT_A_TTY = (
    "racecar-sim: error: teleop reads keys from a terminal (stdin is not a TTY); use --viewer, or run it in a terminal"
)
posix_only = pytest.mark.skipif(os.name != "posix", reason="terminals and signals")


# --- the node, in-process ----------------------------------------------------------------------------
def teleop_sim(**kwargs) -> tuple[Simulator, KeyboardTeleop, Log, list[tuple[float, str]]]:
    """A simulator with a KeyboardTeleop, a log of the teleop input and mux output, and the mux's
    (time, active input) changes."""
    sim = Simulator(lidar=False, camera=False)
    teleop = KeyboardTeleop(sim.bus, sim.scheduler, lambda: sim.time_ns, **kwargs)
    log = Log(sim, TELEOP, OUTPUT)
    changes: list[tuple[float, str]] = []
    sim.subscribe(ACTIVE, lambda m: changes.append((sim.time, m.data)))
    return sim, teleop, log, changes


def holder_at(changes: list[tuple[float, str]], t: float) -> str:
    return [name for when, name in changes if when <= t][-1]


@pytest.mark.parametrize(
    ("key", "speed", "steering"),
    [("w", 0.5, 0.0), ("a", 0.5, 0.25), ("d", 0.5, -0.25), ("s", -0.5, 0.0), ("x", 0.0, 0.0), (" ", 0.0, 0.0)],
)
def test_each_key_sends_the_original_command(key, speed, steering):
    sim, teleop, log, _ = teleop_sim()
    sim.run_until(0.5)
    teleop.key(key)
    msg = log[TELEOP][-1]
    assert (msg.drive.speed, msg.drive.steering_angle) == (speed, steering)
    assert (msg.drive.acceleration, msg.drive.jerk, msg.drive.steering_angle_velocity) == (1.0, 1.0, 1.0)
    assert msg.header.frame_id == "base_link" and msg.header.stamp.sec == 0 and msg.header.stamp.nanosec == 500_000_000
    assert log[OUTPUT][-1] is msg  # teleop outranks the default zero command at once
    assert teleop.drive == msg.drive and teleop.active


def test_speed_and_turn_scale_the_bindings():
    _, teleop, log, _ = teleop_sim(speed=2.0, turn=0.1)
    teleop.key("d")
    assert (log[TELEOP][-1].drive.speed, log[TELEOP][-1].drive.steering_angle) == (2.0, -0.1)


def test_one_key_press_holds_the_mux_then_navigation_takes_back():
    sim, teleop, log, changes = teleop_sim()
    ConstantCommand(sim.bus, sim.scheduler, 1.0, 0.0)
    sim.run_until(1.0)
    assert holder_at(changes, 1.0) == "Navigation"
    teleop.key("a")
    sim.run_until(3.0)
    assert [name for when, name in changes if when >= 1.0] == ["Teleoperation", "idle", "Navigation"]
    start, released, back = (when for when, _ in changes[-3:])
    # repeats at 20 Hz while now < press + hold, then the mux's 0.2 s teleop timeout
    assert start == 1.0 and 0.6 + 0.2 - 1 / 20 - 1e-9 <= released - start <= 0.6 + 0.2 + 1e-9
    assert 0 <= back - released <= 1 / 20 + 1e-9  # the next navigation message
    teleop_out = [m for m in log[OUTPUT] if 1.0 < m.header.stamp.sec + m.header.stamp.nanosec * 1e-9 < released]
    assert teleop_out and all(m.drive.speed == 0.5 and m.drive.steering_angle == 0.25 for m in teleop_out)
    assert not teleop.active


def held_key(sim: Simulator, teleop: KeyboardTeleop, key: str, start: float, stop: float, delay: float = 0.0) -> None:
    """Key events as a terminal's auto-repeat sends them: one at `start`, then every 40 ms from start + delay."""
    sim.scheduler.at(round(start * 1e9), lambda now: teleop.key(key), "press")
    sim.scheduler.every(25.0, lambda now: teleop.key(key) if start + delay <= now * 1e-9 < stop else None, "repeat")


def test_a_held_key_keeps_teleop_in_control_without_a_gap():
    sim, teleop, log, changes = teleop_sim()
    ConstantCommand(sim.bus, sim.scheduler, 1.0, 0.0)
    held_key(sim, teleop, "w", 1.0, 3.0, delay=0.5)  # 0.5 s: a typical keyboard's auto-repeat delay
    sim.run_until(5.0)
    during = [name for when, name in changes if 1.0 <= when < 3.0]
    assert during == ["Teleoperation"]
    times = [o.header.stamp.sec + o.header.stamp.nanosec * 1e-9 for o in log[OUTPUT]]
    window = [(t, m.drive.speed) for t, m in zip(times, log[OUTPUT]) if 1.0 <= t < 3.0]
    assert all(speed == 0.5 for _, speed in window)
    assert max(b - a for (a, _), (b, _) in itertools.pairwise(window)) <= 0.05 + 1e-9
    assert holder_at(changes, 5.0) == "Navigation"


def test_without_hold_the_auto_repeat_delay_lets_navigation_back():
    """--hold 0 is the original: one message per key event, so the car stutters through the auto-repeat delay."""
    sim, teleop, _, changes = teleop_sim(hold=0.0)
    ConstantCommand(sim.bus, sim.scheduler, 1.0, 0.0)
    held_key(sim, teleop, "w", 1.0, 3.0, delay=0.5)
    sim.run_until(3.0)
    assert [name for when, name in changes if 1.0 <= when < 3.0] == [
        "Teleoperation",
        "idle",
        "Navigation",
        "Teleoperation",
    ]


def test_stop_sends_one_zero_command_and_ends_the_repeats():
    sim, teleop, log, _ = teleop_sim()
    teleop.key("w")
    sim.run_until(0.1)
    teleop.stop()
    count = len(log[TELEOP])
    assert log[TELEOP][-1].drive.speed == 0.0 and log[TELEOP][-1].drive.steering_angle == 0.0
    assert log[OUTPUT][-1] is log[TELEOP][-1] and not teleop.active
    sim.run_until(1.0)
    assert len(log[TELEOP]) == count


def test_status_shows_who_drives_not_the_default_commands_route():
    """The 6 Hz zero command holds the low-level mux through its Navigation input: that is idle, not Navigation."""
    sim, teleop, _, changes = teleop_sim()
    labels: list[tuple[float, str]] = []
    sim.scheduler.every(100.0, lambda now: labels.append((now * 1e-9, sim.car.chain.in_control())), "watch")

    def driver(now_ns: int) -> None:  # a driver that drives from 2 s to 4 s, then stops
        if 2.0 <= now_ns * 1e-9 < 4.0:
            sim.publish(NAVIGATION, AckermannDriveStamped(Header.at(now_ns, "base_link"), AckermannDrive(speed=1.0)))

    sim.scheduler.every(20.0, driver, "driver")
    sim.run_until(1.0)
    assert holder_at(changes, 1.0) == "Navigation"  # the low-level mux: the default command's route
    assert sim.car.chain.in_control() == IDLE_ZERO
    teleop.key("w")
    assert sim.car.chain.in_control() == "Teleoperation"
    sim.run_until(6.0)

    def shown(t0: float, t1: float) -> set[str]:
        return {label for t, label in labels if t0 < t < t1}

    assert shown(0.2, 1.0) == {IDLE_ZERO}  # from the first default command, at 1/6 s
    assert shown(1.0, 1.75) == {"Teleoperation"}  # the key's 0.6 s hold, then the mux's 0.2 s timeout
    assert shown(2.0, 4.0) == {"Navigation"}
    assert shown(4.5, 6.0) == {IDLE_ZERO}
    assert {t for t, label in labels if label == "Navigation"} <= {t for t, _ in labels if 2.0 <= t < 4.25}


# --- the terminal layer, on a pseudo-terminal -------------------------------------------------------------
@posix_only
def test_raw_terminal_reads_keys_and_restores_the_mode():
    master, slave = os.openpty()
    try:
        before = termios.tcgetattr(slave)
        with pytest.raises(RuntimeError), RawTerminal(slave) as term:
            mode = termios.tcgetattr(slave)
            assert not mode[3] & (termios.ICANON | termios.ECHO | termios.ISIG)  # lflag: raw input
            assert term.read_keys(0.0) == ""
            os.write(master, b"wa\x03")
            assert term.read_keys(1.0) == "wa\x03"  # Ctrl-C is a character, not a signal
            os.write(master, b"\x1b[A\x1bOBd")  # arrow keys: one unbound ESC each, not an "a" or a "b"
            assert term.read_keys(1.0) == "\x1b\x1bd"
            os.write(master, b"\xff\xc3")
            assert term.read_keys(1.0) == "\ufffd"  # not UTF-8; "\xc3" starts a character
            os.write(master, b"\xa9")
            assert term.read_keys(1.0) == "\u00e9"
            raise RuntimeError("an error inside the block")
        assert termios.tcgetattr(slave) == before
    finally:
        os.close(slave)
        os.close(master)


@posix_only
def test_read_keys_raises_eof_when_the_terminal_closes():
    master, slave = os.openpty()
    try:
        with RawTerminal(slave) as term:
            os.close(master)
            with pytest.raises(EOFError):
                term.read_keys(1.0)
    finally:
        os.close(slave)


@pytest.fixture
def foreground_sigint() -> Iterator[None]:
    """SIGINT handled as in a terminal's foreground, whatever the runner's: a shell's background job starts with it
    ignored, and StopSignals rightly leaves an ignored signal ignored."""
    before = signal.signal(signal.SIGINT, signal.default_int_handler)
    yield
    signal.signal(signal.SIGINT, before)


@posix_only
def test_stop_signals_note_the_first_signal_and_interrupt_on_the_second(foreground_sigint: None):
    previous = signal.getsignal(signal.SIGTERM)
    with StopSignals() as signals:
        # raise_signal: the handler has run when it returns (os.kill's signal may reach another thread of the
        # process, and the main thread run its handler only later)
        signal.raise_signal(signal.SIGTERM)
        assert signals.received == signal.SIGTERM
        with pytest.raises(KeyboardInterrupt):
            signal.raise_signal(signal.SIGINT)
    assert signal.getsignal(signal.SIGTERM) == previous
    ignored = signal.signal(signal.SIGHUP, signal.SIG_IGN)
    try:
        with StopSignals():
            assert signal.getsignal(signal.SIGHUP) == signal.SIG_IGN  # nohup stays nohup
    finally:
        signal.signal(signal.SIGHUP, ignored)


# --- the CLI, through a pseudo-terminal --------------------------------------------------------------------
def spawn(shell: str) -> pexpect.spawn:
    """`shell` under bash in a fresh pty; after it, the exit code and `stty -a` show how the terminal was left."""
    child = pexpect.spawn(
        "bash",
        ["-c", f"{shell}; echo EXIT=$?; stty -a"],
        timeout=TIMEOUT,
        encoding="utf-8",
        codec_errors="replace",
        dimensions=(24, 250),
    )
    child.expect("Reading from the keyboard")
    return child


def pump(child: pexpect.spawn, seconds: float) -> str:
    """What the child prints in the next `seconds` (read, so that a full pty never blocks its status line)."""
    child.expect([pexpect.TIMEOUT, pexpect.EOF], timeout=seconds)
    child.buffer = child.string_type()  # a timeout leaves what was read in the buffer too
    return child.before


def sim_time(child: pexpect.spawn) -> float:
    """Sim time on the newest status line."""
    deadline = time.monotonic() + TIMEOUT
    while time.monotonic() < deadline:
        text = pump(child, 0.1)
        times = re.findall(r"\rt +([0-9.]+) s \|", text)
        if times:
            return float(times[-1])
        assert child.isalive(), f"teleop ended early: {text!r}"
    raise AssertionError(f"no status line in {TIMEOUT} s")


def wait_sim(child: pexpect.spawn, until: float) -> None:
    while sim_time(child) < until:
        pass


def finish(child: pexpect.spawn) -> tuple[int, str]:
    """Exit code and summary line of the CLI; asserts the terminal mode was restored."""
    child.expect(r"EXIT=(\d+)")
    code, output = int(child.match.group(1)), child.before
    child.expect(pexpect.EOF)
    flags = set(re.split(r"[\s;]+", child.before))
    for flag in ("icanon", "echo", "isig", "opost"):
        assert flag in flags and f"-{flag}" not in flags, child.before
    summary = [line for line in output.splitlines() if line.startswith("teleop:")]
    return code, summary[-1] if summary else output


def recorded(path: Path, *topics: str) -> dict[str, list[tuple[float, object]]]:
    """(log time in s, message) of each topic in an MCAP file."""
    from rosbags.highlevel import AnyReader
    from rosbags.typesys import Stores, get_typestore

    out: dict[str, list[tuple[float, object]]] = {t: [] for t in topics}
    with AnyReader([path], default_typestore=get_typestore(Stores.EMPTY)) as reader:
        connections = [c for c in reader.connections if c.topic in topics]
        for connection, stamp, raw in reader.messages(connections=connections):
            out[connection.topic].append((stamp * 1e-9, reader.deserialize(raw, connection.msgtype)))
    return out


def yaw(odom) -> float:
    q = odom.pose.pose.orientation
    return math.atan2(2 * (q.w * q.z + q.x * q.y), 1 - 2 * (q.y * q.y + q.z * q.z))


@posix_only
def test_teleop_drives_the_car_from_a_terminal(tmp_path):
    out = tmp_path / "teleop.mcap"
    child = spawn(f"{CLI} --record {out}")
    for key, seconds in (("w", 2.0), ("a", 1.5)):
        deadline = time.monotonic() + seconds
        while time.monotonic() < deadline:
            child.send(key)  # auto-repeat of a held key
            pump(child, 0.04)
    child.send("x")
    wait_sim(child, sim_time(child) + 1.5)
    child.send("\x03")
    code, summary = finish(child)
    assert code == 0 and "quit" in summary and str(out) in summary, summary

    data = recorded(out, "/vesc/odom", TELEOP, ACTIVE)
    commands = data[TELEOP]
    assert all(
        (m.drive.acceleration, m.drive.jerk, m.drive.steering_angle_velocity) == (1.0, 1.0, 1.0)
        and m.header.frame_id == "base_link"
        for _, m in commands
    )
    drives = [(m.drive.speed, m.drive.steering_angle) for _, m in commands]
    assert set(drives) == {(0.5, 0.0), (0.5, 0.25), (0.0, 0.0)}
    t_w = next(t for t, m in commands if m.drive.speed == 0.5)
    t_a = next(t for t, m in commands if m.drive.steering_angle == 0.25)
    t_x = next(t for t, m in commands if t > t_a and m.drive.speed == 0.0)
    assert drives.index((0.5, 0.25)) > drives.index((0.5, 0.0)) and drives[-1] == (0.0, 0.0)

    changes = [(t, m.data) for t, m in data[ACTIVE]]
    assert holder_at(changes, t_w) == "Teleoperation" and [c for c in changes if t_w < c[0] <= t_x] == []
    odom = data["/vesc/odom"]

    def at(t: float):
        return [m for stamp, m in odom if stamp <= t][-1]

    assert at(t_a).pose.pose.position.x > 0.5 and abs(at(t_a).pose.pose.position.y) < 0.1  # w: straight ahead
    assert yaw(at(t_x)) - yaw(at(t_a)) > 0.2  # a: a left turn
    stopped = [m for stamp, m in odom if stamp >= t_x + 1.0]
    assert stopped and all(abs(m.twist.twist.linear.x) < 0.02 for m in stopped)  # x: stops within 1 s


@posix_only
def test_q_quits_and_unbound_bytes_stop_the_car(tmp_path):
    out = tmp_path / "q.mcap"
    child = spawn(f"{CLI} --hold 0 --record {out}")
    wait_sim(child, 0.2)
    os.write(child.child_fd, b"\xff\x1b[A\x1bOD")  # not UTF-8, arrow up, arrow left: unbound keys, not "a"
    pump(child, 0.2)
    child.send("q")
    code, summary = finish(child)
    assert code == 0 and "quit" in summary, summary
    commands = [m.drive for _, m in recorded(out, TELEOP)[TELEOP]]
    assert len(commands) == 4 and all(d.speed == 0.0 and d.steering_angle == 0.0 for d in commands)


@posix_only
def test_the_status_line_shows_the_speed_along_the_heading_and_the_yaw_rate():
    """Heading 1 rad (x is not the car's forward): `w` at 0.5 m/s reads v +0.50, not the world x part (+0.27)."""
    child = spawn(f"{CLI} --spawn 0,0,1.0")
    lines: list[str] = []
    deadline = time.monotonic() + 2.5
    while time.monotonic() < deadline:
        child.send("w")  # auto-repeat of a held key
        lines += re.findall(r"\rt +[0-9.]+ s \|[^\r]*", pump(child, 0.04))
    child.send("q")
    code, _ = finish(child)
    assert code == 0
    pattern = r"v ([+-][0-9.]+) m/s \| yaw rate ([+-][0-9.]+) rad/s \| .* yaw ([+-][0-9.]+) \|"
    shown = [tuple(float(x) for x in re.search(pattern, line).groups()) for line in lines if "yaw rate" in line]
    speed, yaw_rate, heading = shown[-1]  # after 2.5 s of w: at speed
    assert speed == pytest.approx(0.5, abs=0.02) and heading == pytest.approx(1.0, abs=0.02)
    assert yaw_rate == pytest.approx(0.0, abs=0.02)
    assert 0.5 * math.cos(heading) < 0.3  # what the line showed before: the world-frame x component


@posix_only
def test_duration_ends_the_session():
    child = spawn(f"{CLI} --duration 0.3")
    code, summary = finish(child)
    assert code == 0 and "--duration reached after 0.35 s of sim time" in summary, summary  # + the final stop


@posix_only
def test_sigterm_restores_the_terminal_and_closes_the_recording(tmp_path):
    out = tmp_path / "term.mcap"
    # no job control in bash -c: the background job stays in the terminal's foreground process group
    child = spawn(f"{CLI} --record {out} </dev/tty & echo PID=$!; wait $!")
    pid = int(re.search(r"PID=(\d+)", child.before).group(1))
    wait_sim(child, 0.5)
    os.kill(pid, signal.SIGTERM)
    code, summary = finish(child)
    assert code == 128 + signal.SIGTERM and "signal" in summary, summary
    odom = recorded(out, "/vesc/odom")["/vesc/odom"]
    assert len(odom) >= 10


def test_stdin_not_a_tty_is_a_one_line_error():
    result = subprocess.run(
        [sys.executable, "-m", "racecar_sim", "teleop", "--no-camera"],
        stdin=subprocess.DEVNULL,
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    assert result.returncode == 2 and result.stderr == NOT_A_TTY + "\n"
    assert result.stdout == ""


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="no display is known only where DISPLAY says so")
def test_viewer_without_a_display_and_without_a_tty_has_no_keyboard():
    env = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY")}
    result = subprocess.run(
        [sys.executable, "-m", "racecar_sim", "teleop", "--viewer", "--no-camera"],
        stdin=subprocess.DEVNULL,
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
        env=env,
    )
    assert result.returncode == 2
    assert result.stderr.splitlines()[-1] == (
        "racecar-sim: error: teleop has no keyboard: stdin is not a TTY and the viewer did not open"
    )
