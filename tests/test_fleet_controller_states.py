"""A fleet's controller states at one tick are published together, with the first car's tick: where only a recorder
takes them, in one hand-over of MuJoCo's arrays and a row per controller, not one per car; its joint states too (one
hand-over of every car's joint state, one of every car's /tf made of them). Every car's states are still there at
every tick, once, with the numbers each car alone publishes, through a car deleted, a car spawned (ticking from its
own start) and a reset; the file holds the messages message objects give, in each topic's order (only the order of
different topics within a tick may differ: /tf after every car's joint state, not after each)."""

from __future__ import annotations

from collections import Counter
from pathlib import Path
from typing import Any

import pytest
from mcap.reader import make_reader

from conftest import recorded_messages
from racecar_sim import Car, Simulator, Spawn
from racecar_sim.bus import Bus, RowPacker
from racecar_sim.drivers import ConstantCommand
from racecar_sim.drivers.constant import NAVIGATION
from racecar_sim.msgs import JointControllerState, deserialize, serialize
from racecar_sim.recording.run_recording import RunRecording

STATE = "racecar/left_rear_wheel_velocity_controller/state"
PERIOD_NS = 10_000_000  # 100 Hz, ros_controllers' state rate


def _fleet_run(path: Path, batches: Counter[tuple[str, int]] | None = None) -> bytes:
    """Three constant-command cars in `empty` recorded by RunRecording (a thread) to `path`: car2 deleted at 0.3 s, a
    car4 spawned at 0.405 s (its ticks count from there), a reset at 0.6 s, then 0.3 s more; `batches`: how many
    hand-overs of each (message class, number of messages) there were."""
    publish_cdr_rows = Bus.publish_cdr_rows
    publish_fed_rows = Bus.publish_fed_rows

    def seen(self: Bus, msgtype: type, packer: RowPacker, topics: tuple[str, ...], rows: list[Any]) -> None:
        if batches is not None:
            batches[msgtype.__name__, len(topics)] += 1
        publish_cdr_rows(self, msgtype, packer, topics, rows)

    def fed(self: Bus, msgtype: type, packer: RowPacker, topics: tuple[str, ...], rows: list[Any], more: Any) -> None:
        if batches is not None:
            batches[msgtype.__name__, len(topics)] += 1
        publish_fed_rows(self, msgtype, packer, topics, rows, more)

    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(Bus, "publish_cdr_rows", seen)  # before the cars' views of the bus take it
        patch.setattr(Bus, "publish_fed_rows", fed)
        cars = [
            Car(f"car{k}", spawn=Spawn(-1.5 * (k - 1), 0.0, 0.05, 0.0), camera=False, lidar=False) for k in (1, 2, 3)
        ]
        sim = Simulator(world="empty", cars=cars)
        for k, car in enumerate(sim.cars):
            ConstantCommand(sim.bus, sim.scheduler, 1.0 + 0.5 * k, 0.2 - 0.2 * k, topic=car.topic(NAVIGATION))
        with RunRecording(sim.bus, lambda: sim.time_ns, path, process=False):
            sim.run_until(0.3)
            sim.delete_car(sim.cars[1])
            sim.run_until(0.405)
            spawned = Car("car4", spawn=Spawn(-6.0, 0.0, 0.05, 0.0), camera=False, lidar=False)
            spawned.load()
            sim.spawn_car(spawned)
            sim.run_until(0.6)
            sim.reset()
            sim.run_until(0.3)
        sim.close()
    return path.read_bytes()


def _states(path: Path) -> dict[str, list[tuple[int, int, float]]]:
    """Each car's left rear wheel controller state: (log time, stamp, command) of each message, in file order."""
    found: dict[str, list[tuple[int, int, float]]] = {}
    with open(path, "rb") as stream:
        for _, channel, message in make_reader(stream).iter_messages(log_time_order=False):
            if channel.topic.endswith(STATE):
                msg = deserialize(message.data, "control_msgs/msg/JointControllerState")
                stamp = msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec
                found.setdefault(channel.topic.split("/")[1], []).append((message.log_time, stamp, msg.command))
    return found


def test_a_fleets_states_go_in_one_hand_over_a_tick_through_deletes_spawns_and_resets(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    batches: Counter[tuple[str, int]] = Counter()
    from_rows = _fleet_run(tmp_path / "rows.mcap", batches)
    with monkeypatch.context() as patch:
        patch.setattr(Bus, "cdr_only", lambda self, topic: False)  # every message an object, each car its own
        from_objects = _fleet_run(tmp_path / "objects.mcap")
    assert len(from_rows) > 50_000 and len(from_objects) > 50_000
    from_rows_messages = recorded_messages(tmp_path / "rows.mcap")
    assert from_rows_messages == recorded_messages(tmp_path / "objects.mcap")
    assert sum(topic.endswith("joint_states") for _, topic, _ in from_rows_messages[0]) > 60
    # three cars' 18 states in one hand-over (two after car2 is deleted; three again after the reset, car4 with
    # them), six where a car ticks alone: a fleet's first tick after each rebuild and the reset, and car4 before the
    # reset (its ticks 5 ms off the others')
    states = {size // 6: count for (name, size), count in batches.items() if name == "JointControllerState"}
    assert states[3] >= 25 and states[2] >= 8 and sum(states.values()) < 140, batches
    # the joint states at 50 Hz the same way: three cars' in one hand-over and their /tf in another
    joint_states = {size: count for (name, size), count in batches.items() if name == "JointState"}
    tf = {size: count for (name, size), count in batches.items() if name == "TFMessage"}
    assert joint_states[3] >= 12 and joint_states[2] >= 4 and sum(joint_states.values()) < 70, batches
    assert tf[3] == joint_states[3] and tf[2] == joint_states[2], batches
    states = _states(tmp_path / "rows.mcap")
    assert sorted(states) == ["car1", "car2", "car3", "car4"]
    spawned = 405_000_000  # car4's start: its ticks count from there until the reset
    for car, ticks in states.items():
        times = [log for log, _, _ in ticks]
        assert [stamp for _, stamp, _ in ticks] == times
        cut = _reset_index(times)
        before, after = times[:cut], times[cut:]
        # one state a tick, 10 ms apart from the car's start, as a car alone publishes it
        start = spawned if car == "car4" else 0
        assert before == [start + PERIOD_NS * k for k in range(1, len(before) + 1)], car
        last = {"car2": 300_000_000, "car4": 595_000_000}.get(car, 600_000_000)  # car2 deleted at 0.3 s
        assert before[-1] == last, car
        assert after == ([] if car == "car2" else [PERIOD_NS * k for k in range(1, 31)]), car
    assert len({command for ticks in states.values() for _, _, command in ticks}) > 50  # real numbers compared


def _reset_index(times: list[int]) -> int:
    """Where the log time goes back (the reset), or the end."""
    return next((k for k in range(1, len(times)) if times[k] < times[k - 1]), len(times))


def test_a_car_alone_publishes_what_the_fleet_publishes_for_it(tmp_path: Path) -> None:
    # the numbers in a fleet's hand-over are each car's own: car1's states in a 2-car fleet are the messages a
    # ControllerStatePublisher makes for car1 at that tick
    cars = [Car(f"car{k}", spawn=Spawn(-1.5 * (k - 1), 0.0, 0.05, 0.0), camera=False, lidar=False) for k in (1, 2)]
    sim = Simulator(world="empty", cars=cars)
    for k, car in enumerate(sim.cars):
        ConstantCommand(sim.bus, sim.scheduler, 1.0 + k, 0.3, topic=car.topic(NAVIGATION))
    got: list[tuple[Any, ...]] = []
    sim.bus.tap(lambda topic, msg: None, cdr=lambda topic, cls, data: None, cdr_rows=lambda *rows: got.append(rows))
    for step in range(1, 6):
        sim.run_until(0.1 * step)
        got.clear()
        sim.run_until(0.1 * step + 0.01)  # one tick
        batch = [rows for rows in got if rows[0] is JointControllerState]
        ((_, packer, topics, rows),) = batch
        publishers = [car.controller_manager.state_publisher for car in sim.cars]
        assert topics == tuple(c.topic for p in publishers for c in p.controllers)
        expected = [serialize(p.message(c, sim.time_ns)) for p in publishers for c in p.controllers]
        assert packer.pack_many(rows) == expected
    sim.close()


@pytest.mark.parametrize("closed", [True, False])
def test_a_fleet_leaves_nothing_behind(closed: bool) -> None:
    # the registries that let a fleet's cars find each other (their controller states and joint states here, their
    # lidars' one-call scans in the tunnel's walls) hold nothing that keeps a simulation alive, closed or dropped
    # without close(): its MjData is freed
    import gc
    import weakref

    freed = []
    for _ in range(2):
        cars = [Car(f"car{k}", spawn=Spawn(-1.5 * (k - 1), 0.0, 0.05, 0.0), camera=False) for k in (1, 2)]
        sim = Simulator(world="tunnel", cars=cars)
        sim.run_until(0.05)  # the fleet's controller states, joint states and scans went together
        assert sim.cars[0].lidar is not None and sim.cars[0].lidar._fleet.batches_cast > 0
        freed.append(weakref.ref(sim.data))
        if closed:
            sim.close()
        del sim, cars
    gc.collect()
    assert [ref() for ref in freed] == [None, None]


def _two_cars_recorded(path: Path) -> Simulator:
    """Two cars in `empty` recorded (a writer thread) for 0.2 s; the simulation, closed."""
    cars = [Car(f"car{k}", spawn=Spawn(-1.5 * (k - 1), 0.0, 0.05, 0.0), camera=False, lidar=False) for k in (1, 2)]
    sim = Simulator(world="empty", cars=cars)
    for k, car in enumerate(sim.cars):
        ConstantCommand(sim.bus, sim.scheduler, 1.0 + k, 0.3, topic=car.topic(NAVIGATION))
    with RunRecording(sim.bus, lambda: sim.time_ns, path, process=False):
        sim.run_until(0.2)
    sim.close()
    return sim


def test_a_fleets_tf_packer_unpickles_in_a_writer_without_the_simulation(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # what packs a fleet's /tf (one TfRows per car) crosses to the writer process pickled: a fresh interpreter
    # unpickles it without loading MuJoCo or the control layer (a writer's first fleet tick costs no import of the
    # simulation), and packs each car's last joint state into the /tf message robot_state_publisher made of it (a
    # run of message objects, recorded)
    import pickle
    import subprocess
    import sys

    made = _two_cars_recorded(tmp_path / "rows.mcap").cars[0].joint_states._together
    assert made is not None and len(made.tf_packer.packers) == 2
    with monkeypatch.context() as patch:
        patch.setattr(Bus, "cdr_only", lambda self, topic: False)  # every message an object
        _two_cars_recorded(tmp_path / "objects.mcap")
    last: dict[str, tuple[int, Any]] = {}  # each car's last joint state
    tf: dict[tuple[int, str], bytes] = {}  # each /tf message by log time and the car its frames are of
    with open(tmp_path / "objects.mcap", "rb") as stream:
        for _, channel, message in make_reader(stream).iter_messages(log_time_order=False):
            if channel.topic.endswith("joint_states"):
                last[channel.topic.split("/")[1]] = (
                    message.log_time,
                    deserialize(message.data, "sensor_msgs/msg/JointState"),
                )
            elif channel.topic == "/tf":
                msg = deserialize(message.data, "tf2_msgs/msg/TFMessage")
                tf[message.log_time, msg.transforms[0].header.frame_id.split("/")[0]] = message.data
    rows, expected = [], []
    for k, car in enumerate(("car1", "car2")):
        log_time, js = last[car]
        stamp = (js.header.stamp.sec, js.header.stamp.nanosec)
        rows.append((k, (*stamp, *js.position.tolist(), *js.velocity.tolist(), *js.effort.tolist())))
        expected.append(tf[log_time, car])
    code = (
        "import pickle, sys; packer, rows = pickle.loads(sys.stdin.buffer.read()); packed = packer.pack_many(rows); "
        "heavy = sorted(m for m in ('mujoco', 'racecar_sim.control', 'racecar_sim.physics') if m in sys.modules); "
        "sys.stdout.buffer.write(pickle.dumps((heavy, packed)))"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], input=pickle.dumps((made.tf_packer, rows)), capture_output=True, check=True
    )
    heavy, packed = pickle.loads(out.stdout)
    assert heavy == []
    assert packed == expected and packed[0] != packed[1]


@pytest.mark.parametrize(
    ("rate_hz", "step_ns", "together"),
    [
        (100.0, 2_500_000, True),  # 10 ms: 4 steps of 2.5 ms
        (50.0, 2_500_000, True),  # 20 ms: 8 steps
        (30.0, 2_500_000, False),  # 33.3 ms: not a whole number of ns, let alone of steps
        (100.0, 3_000_000, False),  # 10 ms: 3.33 steps of 3 ms, so the ticks fall on rounded-up steps
        (40.0, 3_000_000, False),  # 25 ms: 8.33 steps
    ],
)
def test_cars_tick_together_only_where_a_tick_is_a_whole_number_of_physics_steps(
    rate_hz: float, step_ns: int, together: bool
) -> None:
    from racecar_sim.control.fleet_ticks import FleetTick, FleetTicks

    assert FleetTick(FleetTicks(), object(), rate_hz, step_ns).together is together  # type: ignore[arg-type]
