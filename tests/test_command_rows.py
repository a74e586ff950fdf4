"""A recorded command path hands its messages to the writer as rows (control/command_rows.py): the same bytes, the
same messages to a subscriber that comes later, the same commands to the physics."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from mcap.reader import make_reader

from racecar_sim import Car, Simulator
from racecar_sim.bus import Bus, RowPacker
from racecar_sim.drivers.constant import NAVIGATION
from racecar_sim.msgs import AckermannDrive, AckermannDriveStamped, Float64, Header, serialize
from racecar_sim.recording.run_recording import RunRecording

PATH = [
    "/car1/vesc/ackermann_cmd_mux/input/navigation",
    "/car1/vesc/high_level/ackermann_cmd_mux/input/nav_0",
    "/car1/vesc/high_level/ackermann_cmd_mux/output",
    "/car1/vesc/low_level/ackermann_cmd_mux/input/navigation",
    "/car1/vesc/low_level/ackermann_cmd_mux/output",
]
WHEEL = "/car1/racecar/left_front_wheel_velocity_controller/command"
HINGE = "/car1/racecar/right_steering_hinge_position_controller/command"
LATER = 0.5  # s: when the later subscriber comes (the default zero command holds the car then)


def _drive(sim: Simulator) -> None:
    """20 Hz commands that change every time, in two frames, silent from 0.3 to 0.6 s: the navigation input times out
    and the default zero command takes both muxes' control, then hands it back (each mux publishes `active`)."""
    topic = sim.cars[0].topic(NAVIGATION)

    def command(now_ns: int) -> None:
        t = now_ns / 1e9
        if 0.3 <= t < 0.6:
            return
        drive = AckermannDrive(steering_angle=0.3 * math.sin(5 * t), speed=1.0 + t)
        sim.bus.publish(topic, AckermannDriveStamped(Header.at(now_ns, "base_link" if t < 0.3 else "odom"), drive))

    sim.scheduler.every(20.0, command, "test driver")


def _run(path: Path | None, listen_from: float | None, rows: bool = True) -> tuple[list[Any], int, np.ndarray]:
    """A car driven 1 s by _drive(), recorded to `path` (None: not recorded), with a subscriber to the high-level
    mux's output and to two controller commands from `listen_from` s on (None: never): what it got, (topic, stamp,
    serialize() bytes) each; how many command messages went to the writer as rows; the final qpos. `rows`: False,
    the bus answers sole_taker(rows=True) as without rows (every message made and published as before)."""
    heard: list[tuple[str, int, bytes]] = []
    handed = 0
    publish_cdr_rows, sole_taker = Bus.publish_cdr_rows, Bus.sole_taker

    def counted(self: Bus, msgtype: type, packer: RowPacker, topics: tuple[str, ...], rows: list[Any]) -> None:
        nonlocal handed
        if msgtype in (AckermannDriveStamped, Float64):
            handed += len(topics)
        publish_cdr_rows(self, msgtype, packer, topics, rows)

    def listen() -> None:
        for topic in (PATH[2], WHEEL, HINGE):
            sim.subscribe(topic, lambda msg, topic=topic: heard.append((topic, sim.time_ns, serialize(msg))))

    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(Bus, "publish_cdr_rows", counted)  # before the car's nodes take the bus's methods
        if not rows:
            patch.setattr(Bus, "sole_taker", lambda self, topic, rows=False: sole_taker(self, topic))
        sim = Simulator(world="empty", cars=[Car("car1", camera=False)])
        _drive(sim)
        recording = None if path is None else RunRecording(sim.bus, lambda: sim.time_ns, path, process=True)
        if listen_from is not None and listen_from > 0:
            sim.run_until(listen_from)
        if listen_from is not None:
            listen()
        sim.run_until(1.0)
        if recording is not None:
            recording.close()
        qpos = sim.data.qpos.copy()
    sim.close()
    return heard, handed, qpos


def _recorded(path: Path, topics: list[str]) -> list[tuple[str, int, bytes]]:
    with open(path, "rb") as stream:
        return [(c.topic, m.log_time, m.data) for _, c, m in make_reader(stream).iter_messages(topics=topics)]


def test_a_command_path_handed_over_as_rows_records_what_a_subscriber_gets(tmp_path: Path) -> None:
    """The command path's messages go to the writer as rows while the recorder alone takes them: run.mcap is byte for
    byte the file of a run that made every message, a subscriber coming at 0.5 s gets from then on the very messages
    of a run where it listened all along (its topics go the old way, the others stay rows around them), and the
    recorded messages are those a subscriber gets."""
    all_along, handed_objects, _ = _run(tmp_path / "objects.mcap", 0.0, rows=False)
    later, handed, _ = _run(tmp_path / "rows.mcap", LATER)
    assert handed_objects == 0
    # rows for the driver's first 6 commands (4 relayed and muxed, 6 controller commands each) and, once the
    # subscriber came, for the 8 commands' 3 path topics it does not listen to (its own and the controllers' go the
    # old way: one of theirs has a subscriber); the default zero command's besides
    assert handed >= (4 + 6) * 6 + 3 * 8
    assert (tmp_path / "rows.mcap").read_bytes() == (tmp_path / "objects.mcap").read_bytes()
    assert later == [item for item in all_along if item[1] > LATER * 1e9]
    assert {topic for topic, _, _ in later} == {PATH[2], WHEEL, HINGE}
    recorded = _recorded(tmp_path / "rows.mcap", [*PATH, WHEEL, HINGE])
    for topic in (PATH[2], WHEEL, HINGE):  # the recorded bytes are the messages' a subscriber gets
        assert [data for t, _, data in recorded if t == topic] == [data for t, _, data in all_along if t == topic]
    commands = {data for t, _, data in recorded if t == PATH[4]}
    assert len(commands) >= 6 + 8  # commands that differ, in two frames: the comparisons compared something
    assert [t for t, _, _ in recorded[:5]] == PATH  # a command's topics in publish() order


def test_the_physics_get_the_same_commands_as_rows_or_objects(tmp_path: Path) -> None:
    """The car ends where it ends with every message made (a subscriber on the path all along), with the messages
    handed over as rows, and with no recording at all: the same bits."""
    _, _, objects = _run(tmp_path / "objects.mcap", 0.0)
    _, handed, rows = _run(tmp_path / "rows.mcap", None)
    _, _, unrecorded = _run(None, None)
    assert handed > 0
    assert np.linalg.norm(rows[:2]) > 0.5  # the car moved
    assert rows.tobytes() == objects.tobytes() == unrecorded.tobytes()


def test_a_bridge_tapping_the_path_gets_every_command_as_a_message(tmp_path: Path) -> None:
    """A tap that decides by itself which topics it wants (a ROS bridge: no listeners epoch) makes the path publish its
    messages as before, from the next command: the bridge gets each one on the topic it wants, as an object, and no
    command goes as rows while it is there; once it is gone, they do again."""
    got: list[Any] = []
    handed = 0
    publish_cdr_rows = Bus.publish_cdr_rows

    def counted(self: Bus, msgtype: type, packer: RowPacker, topics: tuple[str, ...], rows: list[Any]) -> None:
        nonlocal handed
        handed += msgtype is AckermannDriveStamped
        publish_cdr_rows(self, msgtype, packer, topics, rows)

    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(Bus, "publish_cdr_rows", counted)
        sim = Simulator(world="empty", cars=[Car("car1", camera=False)])
        _drive(sim)
        with RunRecording(sim.bus, lambda: sim.time_ns, tmp_path / "run.mcap", process=False):
            sim.run_until(0.2)
            assert handed > 0
            handed, before = 0, sim.bus.count(PATH[2])
            untap = sim.bus.tap(lambda topic, msg: topic == PATH[2] and got.append(msg), wants=lambda t: t == PATH[2])
            sim.run_until(0.9)
            assert handed == 0
            assert len(got) == sim.bus.count(PATH[2]) - before >= 8  # the driver silent for 0.3 s of it
            assert all(type(msg) is AckermannDriveStamped for msg in got)
            untap()
            sim.run_until(1.0)
            assert handed > 0
    sim.close()
