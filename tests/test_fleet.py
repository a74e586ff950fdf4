"""A fleet in one world (issue 11): cars as objects, names from the namespace, cars that see and hit each other,
their own noise, and a reset that keeps every node."""

from __future__ import annotations

import math

import numpy as np
import pytest
from rosbags.highlevel import AnyReader
from rosbags.typesys import Stores, get_typestore

from conftest import Log
from racecar_sim import Car, Simulator, Spawn
from racecar_sim.core.errors import ConfigError, WorldError
from racecar_sim.drivers import ConstantCommand
from racecar_sim.msgs import AckermannDrive, AckermannDriveStamped, Header
from racecar_sim.runtime import Collision

GAP = 1.5  # m between the cars' base_links
CORRIDOR = """<?xml version="1.0"?>
<sdf version="1.6"><world name="corridor">
  <model name="ground"><static>true</static><link name="link">
    <collision name="c"><geometry><plane><normal>0 0 1</normal><size>100 100</size></plane></geometry></collision>
  </link></model>
  <model name="walls"><static>true</static><link name="link">
    <collision name="left"><pose>0 1.2 0.5 0 0 0</pose>
      <geometry><box><size>60 0.1 1</size></box></geometry></collision>
    <collision name="right"><pose>0 -1.2 0.5 0 0 0</pose>
      <geometry><box><size>60 0.1 1</size></box></geometry></collision>
  </link></model>
</world></sdf>
"""


@pytest.fixture
def corridor(tmp_path):
    path = tmp_path / "corridor.world"
    path.write_text(CORRIDOR)
    return str(path)


def column(n: int, **car_options) -> list[Car]:
    """car1 at the origin facing +x, each next one GAP behind the one before."""
    return [Car(f"car{k + 1}", spawn=Spawn(-GAP * k, 0.0, 0.05, 0.0), **car_options) for k in range(n)]


def test_four_cars_see_the_car_in_front_at_the_range_the_geometry_predicts(corridor):
    sim = Simulator(world=corridor, cars=column(4, camera=False), sensor_noise=False)
    scans = Log(sim, *(car.topic("/scan") for car in sim.cars))
    sim.run_until(0.025)  # the first scan, all cars still at their spawn poses
    for k, car in enumerate(sim.cars):
        scan = scans[car.topic("/scan")][-1]
        ranges = np.asarray(scan.ranges)
        assert scan.header.frame_id == f"car{k + 1}/laser"
        origin, axes = car.lidar.ray_origin()
        assert abs(np.asarray(ranges)).min() > 0.5  # never itself: its own boxes and wheels are < 0.2 m away
        ahead = ranges[len(ranges) // 2]  # the beam along the car's x axis
        if k == 0:
            assert ahead == np.inf  # nothing ahead in the open corridor
            continue
        # the car in front: its laser box, the first thing at the ray height on the centre line
        box = sim.model.geom(f"car{k}/laser_collision")
        face_x = sim.data.geom_xpos[box.id][0] - box.size[0]
        assert ahead == pytest.approx(face_x - origin[0], abs=0.01)
        assert car.lidar.one_call_scans == len(scans[car.topic("/scan")])  # the other cars cast in the compiled scan


def test_fleet_names_and_exact_topic_counts_for_ten_seconds(corridor):
    sim = Simulator(world=corridor, cars=column(4, camera=False))
    for car in sim.cars:
        ConstantCommand(sim.bus, sim.scheduler, 0.5, 0.0, topic=car.topic("/vesc/ackermann_cmd_mux/input/navigation"))
        sim.subscribe(car.topic("/scan"), lambda msg: None)
    sim.run_until(10.0)
    assert sim.bus.count("/clock") == 1000
    for k in range(1, 5):
        ns = f"/car{k}"
        assert sim.bus.count(f"{ns}/scan") == 400
        assert sim.bus.count(f"{ns}/vesc/odom") == 200
        assert sim.bus.count(f"{ns}/pf/pose/odom") == 200
        assert sim.bus.count(f"{ns}/racecar/joint_states") == 500
        assert sim.bus.count(f"{ns}/vesc/ackermann_cmd_mux/input/navigation") == 200
    assert "/scan" not in sim.bus.topics() and "/vesc/odom" not in sim.bus.topics()


def test_the_namespaced_tf_tree_is_complete(corridor):
    sim = Simulator(world=corridor, cars=column(3, camera=False, lidar=False))
    edges: set[tuple[str, str]] = set()
    for topic in ("/tf", "/tf_static"):
        sim.subscribe(topic, lambda msg: edges.update((t.header.frame_id, t.child_frame_id) for t in msg.transforms))
    sim.run_until(0.1)
    expected = set()
    for car in sim.cars:
        expected |= {(car.names.frame(j.parent), car.names.frame(j.child)) for j in car.robot.joints.values()}
        expected.add(("map", f"{car.name}/odom"))  # gazebo_odometry's map -> odom, one per car
    assert edges == expected
    # every car's tree hangs from its own base_link; no frame is shared between cars but the world frame
    children = [child for _, child in edges]
    assert len(children) == len(set(children))


def drive_towards(sim: Simulator, car: Car, speed: float) -> None:
    def send(now_ns: int) -> None:
        sim.publish(
            car.topic("/vesc/ackermann_cmd_mux/input/navigation"),
            AckermannDriveStamped(Header.at(now_ns, car.names.frame("base_link")), AckermannDrive(speed=speed)),
        )

    sim.scheduler.every(20.0, send, f"{car.name} driver")


def test_two_cars_driven_head_on_collide_and_the_collision_names_both(corridor):
    cars = [
        Car("red", spawn=Spawn(0.0, 0.0, 0.05, 0.0), camera=False),
        Car("blue", spawn=Spawn(3.0, 0.0, 0.05, math.pi), camera=False),
    ]
    sim = Simulator(world=corridor, cars=cars)
    events: list[Collision] = []
    sim.on_collision(events.append)
    topic = Log(sim, "/racecar_sim/collisions")
    for car in sim.cars:
        drive_towards(sim, car, 1.0)
    sim.run_until(4.0)
    assert events and set(events[0].cars) == {"red", "blue"}
    # they meet near the middle: the front of each (camera box at 0.41 m) closes 3 - 2 x 0.41 m at ~1 m/s each
    assert 0.8 < events[0].time_ns * 1e-9 < 1.8
    assert topic["/racecar_sim/collisions"][0].data in ("red blue", "blue red")
    assert np.isfinite(sim.data.qpos).all() and np.isfinite(sim.data.qvel).all()


def noise_of(car_name: str, seed: int, corridor: str) -> np.ndarray:
    """The noise of one scan of a car (noisy minus noise-free ranges) in a two-car corridor."""
    ranges = []
    for noise in (True, False):
        sim = Simulator(world=corridor, cars=column(2, camera=False), seed=seed, sensor_noise=noise)
        scans = Log(sim, sim.car_named(car_name).topic("/scan"))
        sim.run_until(0.025)
        ranges.append(np.asarray(scans[sim.car_named(car_name).topic("/scan")][-1].ranges, np.float64))
    hit = np.isfinite(ranges[1]) & (ranges[1] > 0.2) & (ranges[1] < 9.8)
    return ranges[0][hit] - ranges[1][hit]


def test_each_car_has_its_own_noise_and_the_seed_reproduces_it(corridor):
    a, b = noise_of("car1", 7, corridor), noise_of("car2", 7, corridor)
    assert 0.007 < a.std() < 0.013 and 0.007 < b.std() < 0.013  # sigma 0.01 from racecar.gazebo
    n = min(len(a), len(b))
    assert abs(np.corrcoef(a[:n], b[:n])[0, 1]) < 0.2  # independent streams, not the same numbers
    assert np.array_equal(a, noise_of("car1", 7, corridor))  # the same seed: the same noise


def test_a_single_car_keeps_the_original_names():
    sim = Simulator(world="empty", camera=False)
    assert sim.car.model_name == "racecar" and sim.cars == [sim.car]
    assert {"/vesc/odom", "/racecar/joint_states", "/vesc/ackermann_cmd_mux/input/navigation"} <= set(sim.bus.topics())
    assert sim.car.lidar.topic == "/scan" and sim.car.lidar.spec.frame_id == "laser"
    assert sim.model.body("base_link").id > 0 and sim.model.joint("left_rear_wheel_joint").id >= 0


def test_fleet_errors_are_one_line_config_errors(corridor):
    with pytest.raises(ConfigError, match="car2"):
        Simulator(world=corridor, cars=[Car("car1"), Car("car2")])  # no spawn for the second car
    with pytest.raises(ConfigError, match="differ"):
        Simulator(world=corridor, cars=[Car("a"), Car("a", spawn=Spawn(-2, 0, 0.05, 0))])
    with pytest.raises(ConfigError, match="car name"):
        Car("2fast")
    with pytest.raises(ConfigError, match="camera"):  # a single-car option next to cars=[...] would be ignored
        Simulator(world=corridor, camera=False, cars=column(2))
    with pytest.raises(WorldError, match="car2"):  # spawned into the first car
        Simulator(
            world=corridor, cars=[Car("car1", camera=False), Car("car2", spawn=Spawn(0.1, 0, 0.05, 0), camera=False)]
        )


# --- a reset that keeps every node --------------------------------------------------------------------------------
class UserDriver:
    """The README's kind of node: a scheduled timer publishing commands, with a reset hook."""

    def __init__(self, sim: Simulator) -> None:
        self.sim, self.sent, self.resets = sim, 0, 0
        sim.scheduler.every(20.0, self.drive, "user_driver")
        sim.on_reset(self.reset)

    def drive(self, now_ns: int) -> None:
        self.sent += 1
        self.sim.publish(
            "/vesc/ackermann_cmd_mux/input/navigation",
            AckermannDriveStamped(Header.at(now_ns, "base_link"), AckermannDrive(speed=1.0)),
        )

    def reset(self) -> None:
        self.resets += 1


def test_reset_keeps_drivers_timers_recorders_and_subscriptions(tmp_path):
    sim = Simulator(world="empty", camera=False)
    driver = UserDriver(sim)
    odom = Log(sim, "/vesc/odom")
    recorder = sim.record(tmp_path / "run.mcap")
    sim.run_until(2.0)
    before = odom["/vesc/odom"][-1].pose.pose.position.x
    assert before > 1.5
    sim.reset()
    assert sim.time == 0.0 and driver.resets == 1
    start = len(odom["/vesc/odom"])
    sim.run_until(2.0)
    after = odom["/vesc/odom"][-1].pose.pose.position.x
    assert after == pytest.approx(before, abs=1e-9)  # the same drive, to the nanometre
    assert len(odom["/vesc/odom"]) - start == 40 and driver.sent == 80
    recorder.close()
    with AnyReader([tmp_path / "run.mcap"], default_typestore=get_typestore(Stores.EMPTY)) as reader:
        counts = {c.topic: c.msgcount for c in reader.connections}
    assert counts["/vesc/odom"] == 80  # the recorder kept recording across the reset


def test_a_reset_asked_for_inside_a_callback_happens_after_that_event():
    sim = Simulator(world="empty", camera=False, lidar=False)
    stamps: list[int] = []
    sim.subscribe("/vesc/odom", lambda msg: stamps.append(msg.header.stamp.to_ns()))
    sim.scheduler.at(500_000_000, lambda now: sim.reset(), "user reset")
    sim.run_until(0.6)
    assert sim.time == pytest.approx(0.6)
    # 20 Hz up to 0.5 s, then the clock starts again at 0: no message is stamped with the old time twice
    assert stamps == [50_000_000 * k for k in range(1, 11)] + [50_000_000 * k for k in range(1, 13)]


def test_reset_with_a_new_seed_changes_the_noise_and_spawn_poses_are_honoured(corridor):
    sim = Simulator(world=corridor, cars=column(2, camera=False), seed=1)
    scans = Log(sim, "/car1/scan", "/car2/odom")
    odom = Log(sim, "/car2/vesc/odom")
    sim.run_until(0.025)
    first = np.asarray(scans["/car1/scan"][-1].ranges)
    sim.reset()
    sim.run_until(0.025)
    assert np.array_equal(np.asarray(scans["/car1/scan"][-1].ranges), first)  # same seed, same noise
    sim.reset(seed=2, spawn={"car2": Spawn(-4.0, 0.5, 0.05, 0.3)})
    sim.run_until(0.05)
    again = np.asarray(scans["/car1/scan"][-1].ranges)
    assert not np.array_equal(again, first)
    pose = odom["/car2/vesc/odom"][-1].pose.pose
    assert (pose.position.x, pose.position.y) == pytest.approx((-4.0, 0.5), abs=2e-3)
    assert 2 * math.atan2(pose.orientation.z, pose.orientation.w) == pytest.approx(0.3, abs=2e-3)
