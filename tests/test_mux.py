"""The command path: ackermann_cmd_mux priorities, timeouts and the default zero command (original_stack.md §4.1)."""

from __future__ import annotations

from conftest import NAVIGATION, TELEOP, Log, ground_speed
from racecar_sim import Simulator
from racecar_sim.drivers import ConstantCommand
from racecar_sim.msgs import AckermannDrive, AckermannDriveStamped, Header

LOW = "/vesc/low_level/ackermann_cmd_mux"


def command_window(sim: Simulator, topic: str, speed: float, start: float, stop: float, rate: float = 20.0) -> None:
    """Publish `speed` on `topic` at `rate` Hz from `start` to `stop` (sim seconds)."""

    def send(now_ns: int) -> None:
        if start <= now_ns * 1e-9 < stop:
            sim.publish(topic, AckermannDriveStamped(Header.at(now_ns), AckermannDrive(speed=speed)))

    sim.scheduler.every(rate, send, f"test {topic}")


def test_teleop_overrides_navigation_then_hands_back_after_its_timeout():
    sim = Simulator()
    log = Log(sim, f"{LOW}/output", f"{LOW}/active")
    stamps: list[float] = []
    sim.subscribe(f"{LOW}/output", lambda m: stamps.append(sim.time))
    command_window(sim, NAVIGATION, 1.0, 0.0, 10.0)
    command_window(sim, TELEOP, -0.5, 2.0, 4.0)
    sim.run_until(6.0)
    out = list(zip(stamps, (m.drive.speed for m in log[f"{LOW}/output"])))
    during = [s for t, s in out if 2.0 < t < 4.0]
    assert during and all(s == -0.5 for s in during)  # teleop (10) beats navigation (0)
    # the last teleop message is at 3.95 s: navigation is blocked until its 0.2 s timeout, then regains
    assert [t for t, s in out if 3.95 < t < 4.15] == []
    first_nav = min(t for t, s in out if t > 4.0 and s == 1.0)
    assert first_nav == 4.15  # the first navigation message at or after the timeout (3.95 + 0.2 s)
    actives = [m.data for m in log[f"{LOW}/active"]]
    assert actives == ["idle", "Navigation", "Teleoperation", "idle", "Navigation"]


def test_default_zero_command_holds_and_stops_the_car():
    sim = Simulator()
    log = Log(sim, "/vesc/odom", f"{LOW}/output", "/vesc/high_level/ackermann_cmd_mux/active")
    command_window(sim, NAVIGATION, 1.0, 0.0, 2.0)
    sim.run_until(6.0)
    moving = [o for o in log["/vesc/odom"] if o.header.stamp.sec == 1]
    assert all(ground_speed(o) > 0.9 for o in moving[-5:])
    stopped = [o for o in log["/vesc/odom"] if o.header.stamp.sec >= 4]
    assert all(ground_speed(o) < 0.01 for o in stopped)  # the 6 Hz default zero command took over
    assert "Default" in [m.data for m in log["/vesc/high_level/ackermann_cmd_mux/active"]]


def test_default_command_runs_at_6_hz_with_nothing_else():
    sim = Simulator()
    log = Log(sim, f"{LOW}/output")
    sim.run_until(10.0)
    assert len(log[f"{LOW}/output"]) == 60
    assert all(m.drive.speed == 0.0 and m.drive.steering_angle == 0.0 for m in log[f"{LOW}/output"])


def test_safety_beats_navigation_but_not_teleop():
    sim = Simulator()
    log = Log(sim, f"{LOW}/output")
    for topic, speed in ((NAVIGATION, 1.0), ("/vesc/ackermann_cmd_mux/input/safety", 0.3), (TELEOP, -0.5)):
        command_window(sim, topic, speed, 0.0, 3.0)
    sim.run_until(3.0)
    speeds = [m.drive.speed for m in log[f"{LOW}/output"]]
    # navigation came first (registered first), then safety took over, then teleop, which keeps control
    assert speeds[0] == 1.0 and speeds[1] == 0.3 and set(speeds[2:]) == {-0.5}


def test_nan_command_is_ignored_not_fatal(caplog):
    sim = Simulator()
    ConstantCommand(sim.bus, sim.scheduler, 1.0, 0.0)
    sim.run_until(1.0)
    sim.publish(TELEOP, AckermannDriveStamped(drive=AckermannDrive(speed=float("nan"))))
    sim.run_until(2.0)
    assert "drive.speed = nan" in caplog.text
    pos, _ = sim.car.state.base_pose()
    assert pos[0] > 1.0  # still driving on the last valid command
