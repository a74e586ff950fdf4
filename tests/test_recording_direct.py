"""A recording whose topics only the recorder takes is written from CDR bytes packed straight from the publishers'
numbers (Bus.publish_cdr): run.mcap holds byte for byte the messages the message objects give, each topic's in their
order (a fleet's joint states of one tick go together, then their /tf, where objects give each car's in turn), and the
moving links' twists are mj_objectVelocity's, bit for bit, and their poses those read one link at a time."""

from __future__ import annotations

import pickle
from pathlib import Path
from typing import Any

import mujoco
import numpy as np
import pytest
from mcap.reader import make_reader

from conftest import needs_gl, recorded_messages
from racecar_sim import Car, Simulator, Spawn
from racecar_sim.bus import Bus, RowPacker
from racecar_sim.cli.main import main
from racecar_sim.drivers import ConstantCommand
from racecar_sim.drivers.constant import NAVIGATION
from racecar_sim.msgs import JointControllerState, deserialize, serialize
from racecar_sim.msgs.link_arrays import LinkArrays
from racecar_sim.recording.run_recording import RunRecording

RUN = ["run", "--world", "empty", "--cars", "3", "--driver", "constant", "--speed", "1", "--no-camera", "--no-video",
       "--no-summary", "--duration", "1.2"]  # fmt: skip
DIRECT = {"/gazebo/link_states", "/gazebo/model_states", "/clock", "/tf"}
ROWS = {"/gazebo/link_states (rows)", "/gazebo/model_states (rows)",
        "/car2/racecar/left_rear_wheel_velocity_controller/state (rows)",
        "/car3/racecar/joint_states (fed rows)", "/tf (rows)",
        "/car2/vesc/low_level/ackermann_cmd_mux/output (rows)",
        "/car3/racecar/left_front_wheel_velocity_controller/command (rows)"}  # fmt: skip


def _run(out: Path, monkeypatch: pytest.MonkeyPatch, objects: bool, command: list[str] = RUN) -> tuple[bytes, set[str]]:
    """run.mcap of `command`, and the topics handed over as bytes (those handed over as rows for a writer to pack
    marked " (rows)"); `objects`: every message made as an object."""
    direct: set[str] = set()
    publish_cdr, publish_cdr_rows, publish_fed_rows = Bus.publish_cdr, Bus.publish_cdr_rows, Bus.publish_fed_rows
    sole_taker = Bus.sole_taker

    def counted(self: Bus, topic: str, msgtype: type, data: bytes) -> None:
        direct.add(topic)
        publish_cdr(self, topic, msgtype, data)

    def counted_rows(self: Bus, msgtype: type, packer: RowPacker, topics: tuple[str, ...], rows: list[Any]) -> None:
        direct.update(f"{topic} (rows)" for topic in topics)
        publish_cdr_rows(self, msgtype, packer, topics, rows)

    def counted_fed(self: Bus, msgtype: type, packer: RowPacker, topics: tuple[str, ...], *rest: Any) -> None:
        direct.update(f"{topic} (fed rows)" for topic in topics)
        publish_fed_rows(self, msgtype, packer, topics, *rest)

    with monkeypatch.context() as patch:
        patch.setattr(Bus, "publish_cdr", counted)
        patch.setattr(Bus, "publish_cdr_rows", counted_rows)
        patch.setattr(Bus, "publish_fed_rows", counted_fed)
        if objects:
            patch.setattr(Bus, "cdr_only", lambda self, topic: False)
            patch.setattr(Bus, "sole_taker", lambda self, topic, rows=False: sole_taker(self, topic))
        assert main([*command, "--out", str(out)]) == 0
    return (out / "run.mcap").read_bytes(), direct


def test_run_mcap_is_the_same_from_bytes_and_from_objects(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    _, none = _run(tmp_path / "objects", monkeypatch, objects=True)
    from_bytes, direct = _run(tmp_path / "bytes", monkeypatch, objects=False)
    assert not none
    assert DIRECT <= direct  # the direct way was taken: the comparison compares something
    assert ROWS <= direct  # and the writer packed the state topics
    assert len(from_bytes) > 100_000
    assert recorded_messages(tmp_path / "bytes" / "run.mcap") == recorded_messages(tmp_path / "objects" / "run.mcap")


def _two_cars_turning() -> Simulator:
    """Two cars in the tunnel, each driven round its own circle (their links move in every direction)."""
    cars = [Car("car1", spawn=Spawn(0.0, 0.0, 0.05, 0.0), camera=False),
            Car("car2", spawn=Spawn(-1.5, 0.0, 0.05, 0.3), camera=False)]  # fmt: skip
    sim = Simulator(world="tunnel", cars=cars)
    for k, car in enumerate(sim.cars):
        ConstantCommand(sim.bus, sim.scheduler, 2.0 + k, 0.3 - 0.5 * k, topic=car.topic(NAVIGATION))
    return sim


def test_link_twists_are_mj_object_velocity_bit_for_bit() -> None:
    sim = _two_cars_turning()
    api = sim.gazebo
    velocity = np.zeros(6)
    compared = 0
    for step in range(1, 40):
        sim.run_until(0.02 * step)
        poses, twists = api.link_arrays()
        for row, body, pose, twist in zip(api._moving_rows.tolist(), api._moving_bodies.tolist(), poses, twists):
            mujoco.mj_objectVelocity(sim.model, sim.data, mujoco.mjtObj.mjOBJ_XBODY, body, velocity, 0)
            assert twist.tobytes() == np.concatenate((velocity[3:], velocity[:3])).tobytes()
            (position, quat), _ = api._link_state(api._links[row], None)  # a link's pose, one by one
            assert pose.tobytes() == np.concatenate((position, quat[1:], quat[:1])).tobytes()
            compared += 1
    assert np.abs(twists).max() > 0.5  # the cars move
    sim.close()
    assert compared > 200


def test_a_writer_derives_the_links_arrays_from_the_ticks_bytes_bit_for_bit() -> None:
    """What a recorded tick hands over (MuJoCo's arrays' bytes) gives a writer process's copy of LinkArrays the
    numbers link_arrays() gives in the simulation, bit for bit (the wheels posed by kinematics, the bases read from
    qpos)."""
    sim = _two_cars_turning()
    api = sim.gazebo
    writers = pickle.loads(pickle.dumps(api._arrays))  # as a writer process unpickles it
    assert len(api._posed_links) > 0 and len(api._free_links) == 2  # both ways of reading a pose are compared
    for step in range(1, 12):
        sim.run_until(0.05 * step)
        row = api._state_arrays()
        derived = writers.derive(row)
        assert writers.derive(row) is derived  # the link and the model states of a tick derive them once
        for mine, theirs in zip(api.link_arrays(), derived):
            assert mine.tobytes() == theirs.tobytes()
    assert np.abs(derived[1]).max() > 0.5  # the cars move
    sim.close()


def test_derive_gives_of_s_arrays_bit_for_bit_with_and_without_posed_links() -> None:
    """LinkArrays.derive (one gather from a row's bytes, of()'s arithmetic on the gathered numbers) gives what of()
    gives on the same arrays, bit for bit: free-joint links alone (no posed data: its arrays empty, as a tick hands
    them over), free and posed links mixed in any order of bodies and roots, and rows of another model's sizes after
    them (a new recipe)."""
    rng = np.random.default_rng(3)

    def state(bodies: int, qpos: int, posed: bool) -> list[np.ndarray]:
        kin = [rng.normal(size=(bodies, 3)), rng.normal(size=(bodies, 4))] if posed else [np.empty(0), np.empty(0)]
        return [rng.normal(size=qpos), *kin, *(rng.normal(size=(bodies, k)) * 3 for k in (3, 3, 6))]

    free_only = LinkArrays(np.array([[0, 1, 2, 4, 5, 6, 3], [7, 8, 9, 11, 12, 13, 10]]), np.array([], int),
                           np.array([1, 4]), np.array([1, 4]))  # fmt: skip
    mixed = LinkArrays(np.array([[2, 3, 4, 6, 7, 8, 5]]), np.array([5, 2, 3]), np.array([1, 5, 2, 3]),
                       np.array([1, 1, 1, 4]))  # fmt: skip
    for arrays, sizes in ((free_only, (6, 14, False)), (mixed, (7, 9, True)), (mixed, (9, 12, True))):
        for _ in range(5):
            numbers = state(*sizes)
            row = tuple(a.tobytes() for a in numbers)
            qpos, kin_xpos, kin_xquat, xpos, subtree_com, cvel = numbers
            if not sizes[2]:
                kin_xpos, kin_xquat = np.empty((0, 3)), np.empty((0, 4))
            expected = arrays.of(qpos, kin_xpos, kin_xquat, xpos, subtree_com, cvel)
            derived = arrays.derive(row)
            assert [a.shape for a in derived] == [a.shape for a in expected]
            assert [a.tobytes() for a in derived] == [a.tobytes() for a in expected]
            assert np.abs(expected[1][:, :3]).max() > 1  # the offsets' cross products count


def test_a_writers_controller_rows_pack_the_states_messages_bytes() -> None:
    """A recorded tick's controller states, handed over as MuJoCo's arrays' bytes, packed by a writer process's copy
    of ControllerRows: each the bytes of the message the publisher makes of the same state (velocity controllers with
    their I-term, position controllers with their PID integral), while the car speeds up and steers."""
    sim = Simulator(world="empty", cars=[Car("car1", camera=False)])
    ConstantCommand(sim.bus, sim.scheduler, 2.0, 0.3, topic=sim.cars[0].topic(NAVIGATION))
    publisher = sim.cars[0].controller_manager.state_publisher
    got: list[tuple[type, RowPacker, tuple[str, ...], list[Any]]] = []
    sim.bus.tap(lambda topic, msg: None, cdr=lambda topic, cls, data: None, cdr_rows=lambda *rows: got.append(rows))
    commands = set()
    for step in range(1, 8):
        sim.run_until(0.1 * step)
        got.clear()
        publisher.publish(sim.time_ns)
        ((cls, packer, topics, rows),) = got
        assert cls is JointControllerState and topics == tuple(c.topic for c in publisher.controllers)
        writers = pickle.loads(pickle.dumps(packer))  # as a writer process unpickles it
        expected = [serialize(publisher.message(c, sim.time_ns)) for c in publisher.controllers]
        assert writers.pack_many(rows) == expected
        handed = pickle.loads(pickle.dumps(rows, 5))  # the rows as a hand-over gives them: one tick shared
        assert len({id(tick) for _, tick in handed}) == 1 and writers.pack_many(handed) == expected
        commands.update(deserialize(data, "control_msgs/msg/JointControllerState").command for data in expected)
    assert len(commands) > 20  # every controller's command changes as the car speeds up: real numbers compared
    sim.close()


def _one_car(path: Path, process: bool, listened: str | None = None, stopped: str | None = None) -> bytes:
    """A constant-command car's 0.7 s recorded by RunRecording to `path`; `listened`: a topic a subscriber takes too;
    `stopped`: a controller stopped from 0.3 s to 0.5 s."""
    sim = Simulator(world="empty", cars=[Car("car1", camera=False)])
    ConstantCommand(sim.bus, sim.scheduler, 1.5, 0.2, topic=sim.cars[0].topic(NAVIGATION))
    if listened is not None:
        sim.subscribe(listened, lambda msg: None)
    with RunRecording(sim.bus, lambda: sim.time_ns, path, process=process):
        if stopped is not None:
            manager = sim.cars[0].controller_manager
            sim.run_until(0.3)
            assert manager.stop(stopped)
            sim.run_until(0.5)
            assert manager.start(stopped)
        sim.run_until(0.7)
    sim.close()
    return path.read_bytes()


@pytest.mark.parametrize("process", [False, True])
def test_run_recording_writes_the_same_bytes_both_ways(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, process: bool
) -> None:
    """RunRecording on a writer thread (no process) and on a writer process: the same file from bytes and objects."""
    with monkeypatch.context() as patch:
        patch.setattr(Bus, "cdr_only", lambda self, topic: False)
        from_objects = _one_car(tmp_path / "objects.mcap", process)
    from_bytes = _one_car(tmp_path / "bytes.mcap", process)
    assert len(from_bytes) > 20_000 and from_bytes == from_objects


def test_controller_states_partly_taken_by_a_subscriber_keep_their_order(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """One of a car's controller states also taken by a subscriber goes as an object, those before and after it as
    bytes handed over together: the file is the one the objects give, message for message in the same order."""
    listened = "/car1/racecar/right_front_wheel_velocity_controller/state"  # one in the middle of the six
    with monkeypatch.context() as patch:
        patch.setattr(Bus, "cdr_only", lambda self, topic: False)
        from_objects = _one_car(tmp_path / "objects.mcap", False, listened)
    batches: list[list[str]] = []
    publish_cdr_rows = Bus.publish_cdr_rows

    def seen(self: Bus, msgtype: type, packer: RowPacker, topics: tuple[str, ...], rows: list[Any]) -> None:
        if msgtype is JointControllerState:
            batches.append(list(topics))
        publish_cdr_rows(self, msgtype, packer, topics, rows)

    with monkeypatch.context() as patch:
        patch.setattr(Bus, "publish_cdr_rows", seen)
        from_bytes = _one_car(tmp_path / "bytes.mcap", False, listened)
    assert batches and all(listened not in batch for batch in batches)
    assert {len(batch) for batch in batches} == {2, 3}  # the six less the one, before it and after it
    assert from_bytes == from_objects


def test_a_stopped_controller_state_is_left_out_of_the_bytes_as_of_the_objects(tmp_path: Path) -> None:
    """A controller stopped for a while publishes no state (ros_control): the car's other states still go as bytes,
    and the file is the one the objects give."""
    stopped = "left_rear_wheel_velocity_controller"
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(Bus, "cdr_only", lambda self, topic: False)
        from_objects = _one_car(tmp_path / "objects.mcap", False, stopped=stopped)
    from_bytes = _one_car(tmp_path / "bytes.mcap", True, stopped=stopped)
    assert from_bytes == from_objects
    with open(tmp_path / "bytes.mcap", "rb") as stream:
        counts = make_reader(stream).get_summary().statistics.channel_message_counts  # type: ignore[union-attr]
        topics = {c.id: c.topic for c in make_reader(stream).get_summary().channels.values()}  # type: ignore[union-attr]
    states = {topics[k]: n for k, n in counts.items() if topics[k].endswith("/state")}
    assert (
        states[f"/car1/racecar/{stopped}/state"]
        == states["/car1/racecar/right_rear_wheel_velocity_controller/state"] - 20
    )


@needs_gl
def test_camera_info_from_bytes_makes_the_same_run_mcap(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """The camera's CameraInfo, whose only taker is the recorder, goes as bytes packed from its stamp: the file (JPEG
    frames and infos) is the one the message objects give."""
    run = ["run", "--world", "walker", "--driver", "wall-follow", "--no-video", "--no-summary", "--duration", "0.3"]
    _, none = _run(tmp_path / "objects", monkeypatch, objects=True, command=run)
    from_bytes, direct = _run(tmp_path / "bytes", monkeypatch, objects=False, command=run)
    assert not none
    assert "/camera/zed/rgb/camera_info" in direct
    assert len(from_bytes) > 100_000
    assert recorded_messages(tmp_path / "bytes" / "run.mcap") == recorded_messages(tmp_path / "objects" / "run.mcap")


def _listened_car(path: Path, listen_from: float) -> tuple[list[tuple[str, int, bytes]], int]:
    """A turning car's 1 s recorded by a writer process to `path`, with a subscriber to its joint states and to /tf
    from `listen_from` s on: what the subscriber got, (topic, stamp, serialize() bytes) each, and how many joint
    states went to the writer as rows (publish_fed_rows)."""
    heard: list[tuple[str, int, bytes]] = []
    fed = 0
    publish_fed_rows = Bus.publish_fed_rows

    def counted(self: Bus, *args: Any) -> None:
        nonlocal fed
        fed += 1
        publish_fed_rows(self, *args)

    def listen(topic: str) -> None:
        sim.subscribe(topic, lambda msg: heard.append((topic, msg_stamp(msg), serialize(msg))))

    def msg_stamp(msg: Any) -> int:
        header = msg.header if hasattr(msg, "header") else msg.transforms[0].header
        return int(header.stamp.sec) * 1_000_000_000 + int(header.stamp.nanosec)

    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(Bus, "publish_fed_rows", counted)  # before the car's nodes take the bus's methods
        sim = Simulator(world="empty", cars=[Car("car1", camera=False)])
        ConstantCommand(sim.bus, sim.scheduler, 1.5, 0.3, topic=sim.cars[0].topic(NAVIGATION))
        with RunRecording(sim.bus, lambda: sim.time_ns, path, process=True):
            if listen_from:
                sim.run_until(listen_from)
            listen(JOINT_STATES)
            listen("/tf")
            sim.run_until(1.0)
    sim.close()
    return heard, fed


JOINT_STATES = "/car1/racecar/joint_states"


def test_joint_states_and_tf_packed_by_the_writer_are_the_messages_a_subscriber_gets(tmp_path: Path) -> None:
    """Joint states and their /tf, handed to the writer as rows while the recorder alone takes them: run.mcap holds
    the bytes of the very messages a subscriber gets in a run where it listens all along, and a subscriber that
    comes later still gets every one (the objects again), the same messages."""
    all_along, fed_all_along = _listened_car(tmp_path / "objects.mcap", 0.0)
    later, fed = _listened_car(tmp_path / "rows.mcap", 0.5)
    assert fed_all_along == 0 and 20 <= fed <= 26  # rows for 0.5 s at 50 Hz, and none once someone listened
    assert later == [item for item in all_along if item[1] > 500_000_000]  # the later subscriber misses nothing
    assert [topic for topic, _, _ in later].count(JOINT_STATES) == 25
    recorded = (tmp_path / "rows.mcap").read_bytes()
    assert recorded == (tmp_path / "objects.mcap").read_bytes()
    with open(tmp_path / "rows.mcap", "rb") as stream:
        messages = [(c.topic, m.data) for _, c, m in make_reader(stream).iter_messages(topics=[JOINT_STATES, "/tf"])]
    for topic in (JOINT_STATES, "/tf"):  # each topic's messages in order (a subscriber hears /tf before the state)
        assert [data for t, data in messages if t == topic] == [data for t, _, data in all_along if t == topic]
    states = [deserialize(data, "sensor_msgs/msg/JointState") for topic, data in messages if topic == JOINT_STATES]
    positions = {tuple(state.position) for state in states}
    assert len(positions) == 50  # the wheels turn and the hinges steer: fifty different joint states compared
