"""Gazebo's ROS API (issue 11 item 6): /gazebo/link_states and /gazebo/model_states named as Gazebo names them,
the model pose equal to /vesc/odom's, and the get/set_model_state, spawn_urdf/sdf_model, delete_model, pause,
unpause and reset services."""

from __future__ import annotations

import math

import numpy as np
import pytest
from rosbags.highlevel import AnyReader
from rosbags.typesys import Stores, get_typestore

from conftest import Log
from racecar_sim import Car, Simulator, Spawn
from racecar_sim.core.transforms import quat_from_axis_angle
from racecar_sim.description import DEFAULT_XACRO, expand_xacro
from racecar_sim.drivers import ConstantCommand
from racecar_sim.msgs import Point, Pose, Quaternion, Twist, Vector3
from racecar_sim.msgs.gazebo_msgs import (
    DeleteModelRequest,
    GetModelStateRequest,
    GetWorldPropertiesRequest,
    ModelState,
    SetModelStateRequest,
    SpawnModelRequest,
)
from racecar_sim.msgs.std_srvs import EmptyRequest
from racecar_sim.recording.run_recording import RunRecording
from racecar_sim.runtime.gazebo_api import LINK_STATES, MODEL_STATES, STATES_RATE

WHEELS = ("left_rear_wheel", "right_rear_wheel", "left_front_wheel", "right_front_wheel")
HINGES = ("left_steering_hinge", "right_steering_hinge")
LASER = (0.265, 0.0, 0.1374)  # laser ray origin in base_link (original_stack.md §1.4)
AHEAD = 540  # the beam along the laser's x axis (1081 beams, 0.25 degrees apart)
# A closed corridor: inner faces at y = +-HALF_WIDTH and x = +-HALF_LENGTH
HALF_WIDTH, HALF_LENGTH = 1.45, 5.95
CORRIDOR = f"""<?xml version="1.0"?>
<sdf version="1.6"><world name="corridor">
  <model name="ground_plane"><static>true</static><link name="link">
    <collision name="c"><geometry><plane><normal>0 0 1</normal><size>100 100</size></plane></geometry></collision>
  </link></model>
  <model name="walls"><static>true</static>
    <link name="left"><pose>0 {HALF_WIDTH + 0.05} 0.5 0 0 0</pose>
      <collision name="c"><geometry><box><size>12 0.1 1</size></box></geometry></collision></link>
    <link name="right"><pose>0 {-HALF_WIDTH - 0.05} 0.5 0 0 0</pose>
      <collision name="c"><geometry><box><size>12 0.1 1</size></box></geometry></collision></link>
    <link name="front"><pose>{HALF_LENGTH + 0.05} 0 0.5 0 0 0</pose>
      <collision name="c"><geometry><box><size>0.1 3.1 1</size></box></geometry></collision></link>
    <link name="back"><pose>{-HALF_LENGTH - 0.05} 0 0.5 0 0 0</pose>
      <collision name="c"><geometry><box><size>0.1 3.1 1</size></box></geometry></collision></link>
  </model>
</world></sdf>
"""
BOX = """<sdf version="1.6"><model name="{name}"><static>{static}</static><link name="link">
  <inertial><mass>2.0</mass><inertia><ixx>0.1</ixx><iyy>0.1</iyy><izz>0.1</izz></inertia></inertial>
  <collision name="c"><geometry><box><size>0.5 0.5 0.5</size></box></geometry></collision>
  <visual name="v"><geometry><box><size>0.5 0.5 0.5</size></box></geometry></visual>
</link></model></sdf>"""


def _sim(world: str = "empty", **kwargs) -> Simulator:
    if "cars" in kwargs:  # a fleet takes its sensor switches per car
        return Simulator(world=world, **kwargs)
    return Simulator(world=world, camera=False, **kwargs)


def _stamp(msg) -> int:
    return msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec


def _pose(x: float, y: float, z: float = 0.0, yaw: float = 0.0) -> Pose:
    w, qx, qy, qz = quat_from_axis_angle((0.0, 0.0, 1.0), yaw)
    return Pose(Point(x, y, z), Quaternion(qx, qy, qz, w))


def _scan(sim: Simulator) -> np.ndarray:
    """The next scan, from the current state."""
    log = Log(sim, "/scan")
    sim.run_for(0.025)
    return log["/scan"][-1].ranges


def _position(sim: Simulator, model: str) -> np.ndarray:
    res = sim.bus.call("/gazebo/get_model_state", GetModelStateRequest(model))
    assert res.success, res.status_message
    return np.array([res.pose.position.x, res.pose.position.y, res.pose.position.z])


# --- topics ------------------------------------------------------------------------------------------------------
def test_states_name_models_and_links_as_gazebo_does_at_100_hz():
    sim = _sim("cones")
    log = Log(sim, MODEL_STATES, LINK_STATES)
    times: list[int] = []
    sim.subscribe(MODEL_STATES, lambda msg: times.append(sim.time_ns))
    sim.run_until(1.0)
    assert STATES_RATE == 100.0
    assert len(log[MODEL_STATES]) == len(log[LINK_STATES]) == 100
    assert times == [10_000_000 * k for k in range(1, 101)]
    models = log[MODEL_STATES][-1]
    assert models.name == ["ground_plane", "cone_1", "cone_2", "cone_3", "cone_4", "cone_5", "racecar"]
    links = log[LINK_STATES][-1].name
    assert links[:6] == ["ground_plane::link"] + [f"cone_{k}::link" for k in range(1, 6)]
    assert sorted(links[6:]) == sorted(f"racecar::{link}" for link in ("base_link", *WHEELS, *HINGES))
    assert links[6] == "racecar::base_link"  # 7 links: the fixed ones merged into base_link, as Gazebo merges them
    cone = models.pose[models.name.index("cone_3")]
    assert (cone.position.x, cone.position.y) == pytest.approx((3.0, 0.0), abs=1e-6)
    assert len(models.pose) == len(models.twist) == 7


def test_nobody_listening_nothing_published():
    sim = _sim()
    sim.run_until(0.5)
    assert sim.bus.count(MODEL_STATES) == sim.bus.count(LINK_STATES) == 0


def test_a_fleet_is_named_by_model():
    sim = _sim(cars=[Car("car1", camera=False), Car("car2", spawn=Spawn(0.0, 2.0, 0.05, 0.0), camera=False)])
    links = sim.gazebo.link_states().name
    assert sim.gazebo.model_names == ["ground_plane", "car1", "car2"]
    assert "car1::base_link" in links and "car2::base_link" in links and "car2::left_front_wheel" in links
    pose = sim.gazebo.model_states().pose[2]
    assert (pose.position.x, pose.position.y) == pytest.approx((0.0, 2.0))


def test_tunnel_model_pose_is_where_the_world_file_puts_it():
    states = _sim("tunnel", lidar=False).gazebo.model_states()
    assert states.name == ["ground_plane", "MIT_Tunnel", "racecar"]
    assert (states.pose[1].position.x, states.pose[1].position.y) == (6.0, 20.0)


def test_model_pose_equals_odom_pose_at_equal_stamps():
    sim = _sim()
    ConstantCommand(sim.bus, sim.scheduler, speed=1.5, steering_angle=0.3)
    log = Log(sim, "/vesc/odom")
    by_time: dict[int, tuple] = {}
    sim.subscribe(MODEL_STATES, lambda msg: by_time.__setitem__(sim.time_ns, (msg, sim.gazebo.link_states())))
    sim.run_until(2.0)
    assert len(log["/vesc/odom"]) == 40
    for odom in log["/vesc/odom"]:
        models, links = by_time[_stamp(odom)]
        assert models.pose[models.name.index("racecar")] == odom.pose.pose  # exactly: same bits
        assert models.twist[models.name.index("racecar")] == odom.twist.twist
        assert links.pose[links.name.index("racecar::base_link")] == odom.pose.pose
    assert log["/vesc/odom"][-1].pose.pose.position.x > 1.0  # it drove: the poses compared are not all zero


# --- get and set --------------------------------------------------------------------------------------------------
def test_get_model_state_of_a_car_and_a_cone():
    sim = _sim("cones")
    sim.run_until(0.5)
    res = sim.bus.call("/gazebo/get_model_state", GetModelStateRequest("racecar"))
    assert res.success and res.header.stamp.sec == 0 and res.header.stamp.nanosec == 500_000_000
    pos, quat = sim.car.state.base_pose()
    assert (res.pose.position.x, res.pose.position.y, res.pose.position.z) == tuple(pos)
    assert _position(sim, "cone_2") == pytest.approx((2.0, 0.0, 0.0), abs=1e-3)
    rel = sim.bus.call("/gazebo/get_model_state", GetModelStateRequest("cone_2", "racecar"))
    assert rel.success and rel.header.frame_id == "racecar"
    assert rel.pose.position.x == pytest.approx(2.0 - pos[0], abs=1e-6)
    link = sim.bus.call("/gazebo/get_model_state", GetModelStateRequest("cone_2", "cone_1::link"))
    assert link.success and link.pose.position.x == pytest.approx(1.0, abs=1e-3)
    props = sim.bus.call("/gazebo/get_world_properties", GetWorldPropertiesRequest())
    assert props.success and props.sim_time == 0.5 and "cone_5" in props.model_names


def test_unknown_models_and_frames_fail_with_a_message():
    sim = _sim("cones")
    res = sim.bus.call("/gazebo/get_model_state", GetModelStateRequest("cone_9"))
    assert not res.success and "cone_9" in res.status_message and "does not exist" in res.status_message
    res = sim.bus.call("/gazebo/get_model_state", GetModelStateRequest("cone_1", "nowhere"))
    assert not res.success and "relative_entity_name" in res.status_message
    res = sim.bus.call("/gazebo/set_model_state", SetModelStateRequest(ModelState("cone_9", _pose(1, 1))))
    assert not res.success and "does not exist" in res.status_message
    res = sim.bus.call("/gazebo/set_model_state", SetModelStateRequest(ModelState("ground_plane", _pose(1, 1))))
    assert not res.success and "static" in res.status_message
    res = sim.bus.call("/gazebo/delete_model", DeleteModelRequest("cone_9"))
    assert not res.success and "does not exist" in res.status_message
    res = sim.bus.call("/gazebo/delete_model", DeleteModelRequest("racecar"))
    assert not res.success and "last car" in res.status_message


def _predicted_ranges(x: float, y: float, yaw: float, count: int, angle_min: float, step: float) -> np.ndarray:
    """Ranges from the laser of a level car at (x, y, yaw) to the corridor's walls, by plain geometry."""
    ox = x + LASER[0] * math.cos(yaw) - LASER[1] * math.sin(yaw)
    oy = y + LASER[0] * math.sin(yaw) + LASER[1] * math.cos(yaw)
    angles = yaw + angle_min + step * np.arange(count)
    c, s = np.cos(angles), np.sin(angles)
    with np.errstate(divide="ignore", invalid="ignore"):
        tx = np.where(c > 0, (HALF_LENGTH - ox) / c, np.where(c < 0, (-HALF_LENGTH - ox) / c, np.inf))
        ty = np.where(s > 0, (HALF_WIDTH - oy) / s, np.where(s < 0, (-HALF_WIDTH - oy) / s, np.inf))
    return np.minimum(tx, ty)


def test_set_model_state_teleports_the_car_and_its_next_scan_sees_the_new_pose(tmp_path):
    path = tmp_path / "corridor.world"
    path.write_text(CORRIDOR)
    sim = _sim(str(path), sensor_noise=False)
    assert sim.gazebo.model_names == ["ground_plane", "walls", "racecar"]
    sim.run_until(0.5)
    z = float(sim.car.state.base_pose()[0][2])  # resting height: the car lands where it stands
    for x, y, yaw in ((2.0, 0.5, 0.3), (-3.0, -0.8, math.pi / 2 + 0.2), (4.5, 0.0, math.pi)):
        res = sim.bus.call("/gazebo/set_model_state", SetModelStateRequest(ModelState("racecar", _pose(x, y, z, yaw))))
        assert res.success, res.status_message
        assert _position(sim, "racecar")[:2] == pytest.approx((x, y), abs=1e-12)
        scan = _scan(sim)
        spec = sim.car.lidar.spec
        predicted = _predicted_ranges(x, y, yaw, len(scan), spec.min_angle, spec.angle_increment)
        near = predicted < spec.range_max - 0.5
        assert near.sum() > 500
        np.testing.assert_allclose(scan[near], predicted[near], atol=5e-3)
        assert np.isinf(scan[predicted > spec.range_max + 0.5]).all()
    # a reference frame: 1 m ahead of where the car stands now
    res = sim.bus.call(
        "/gazebo/set_model_state", SetModelStateRequest(ModelState("racecar", _pose(1.0, 0.0, 0.0), Twist(), "racecar"))
    )
    assert res.success and _position(sim, "racecar")[:2] == pytest.approx((3.5, 0.0), abs=1e-4)


def test_set_model_state_moves_a_cone_and_gives_it_a_twist():
    sim = _sim("cones")
    twist = Twist(Vector3(0.5, 0.0, 0.0))
    res = sim.bus.call(
        "/gazebo/set_model_state", SetModelStateRequest(ModelState("cone_3", _pose(3.0, 2.0, 0.1), twist))
    )
    assert res.success
    assert _position(sim, "cone_3") == pytest.approx((3.0, 2.0, 0.1), abs=1e-9)
    state = sim.bus.call("/gazebo/get_model_state", GetModelStateRequest("cone_3"))
    assert state.twist.linear.x == pytest.approx(0.5)
    sim.bus.publish("/gazebo/set_model_state", ModelState("cone_4", _pose(-2.0, -2.0)))  # the topic does the same
    assert _position(sim, "cone_4")[:2] == pytest.approx((-2.0, -2.0))


# --- spawn and delete -----------------------------------------------------------------------------------------------
def test_spawn_urdf_model_adds_a_second_car_that_drives():
    sim = _sim()
    sim.run_until(0.5)
    first = sim.data.qpos[:7].copy()
    urdf = expand_xacro(DEFAULT_XACRO, {})
    res = sim.bus.call("/gazebo/spawn_urdf_model", SpawnModelRequest("car2", urdf, "car2", _pose(0.0, 3.0, 0.05)))
    assert res.success, res.status_message
    assert np.array_equal(sim.data.qpos[:7], first)  # recompiling kept the first car's state
    assert [car.model_name for car in sim.cars] == ["racecar", "car2"]
    assert sim.gazebo.model_names == ["ground_plane", "racecar", "car2"]
    log = Log(sim, "/car2/vesc/odom", "/vesc/odom", "/car2/scan")
    ConstantCommand(
        sim.bus, sim.scheduler, speed=1.0, steering_angle=0.0, topic="/car2/vesc/ackermann_cmd_mux/input/navigation"
    )
    sim.run_until(2.5)
    odom = log["/car2/vesc/odom"]
    assert len(odom) == 40 and _stamp(odom[0]) == 550_000_000  # its timers start when it is spawned
    assert odom[-1].pose.pose.position.x > 1.0 and odom[-1].pose.pose.position.y == pytest.approx(3.0, abs=0.05)
    assert len(log["/car2/scan"]) == 80
    assert np.abs(sim.data.qpos[:3] - first[:3]).max() < 1e-4  # the first car stood still
    assert all(o.pose.pose.position.x == pytest.approx(first[0], abs=1e-4) for o in log["/vesc/odom"])
    links = sim.gazebo.link_states().name
    assert "car2::base_link" in links and "car2::right_steering_hinge" in links
    again = sim.bus.call("/gazebo/spawn_urdf_model", SpawnModelRequest("car2", urdf, "car2", _pose(0.0, -3.0)))
    assert not again.success and "already exists" in again.status_message
    clash = sim.bus.call("/gazebo/spawn_urdf_model", SpawnModelRequest("car3", urdf, "", _pose(0.0, 0.2, 0.05)))
    assert not clash.success and "inside" in clash.status_message  # spawned into the first car
    assert sim.gazebo.model_names == ["ground_plane", "racecar", "car2"]
    assert not sim.bus.call("/gazebo/spawn_urdf_model", SpawnModelRequest("car4", "<sdf/>", "")).success


def test_delete_model_takes_a_car_and_its_nodes_away():
    sim = _sim(cars=[Car("car1", camera=False), Car("car2", spawn=Spawn(0.0, 2.0, 0.05, 0.0), camera=False)])
    log = Log(sim, "/car2/vesc/odom", "/car1/vesc/odom")
    sim.run_until(0.5)
    res = sim.bus.call("/gazebo/delete_model", DeleteModelRequest("car2"))
    assert res.success, res.status_message
    sim.run_until(1.0)
    assert len(log["/car2/vesc/odom"]) == 10 and len(log["/car1/vesc/odom"]) == 20
    assert [car.model_name for car in sim.cars] == ["car1"]
    assert sim.gazebo.model_names == ["ground_plane", "car1"]


def test_spawn_sdf_model_box_appears_in_the_scan_and_delete_takes_it_away():
    sim = _sim(sensor_noise=False)
    assert np.isinf(_scan(sim)[AHEAD])
    res = sim.bus.call(
        "/gazebo/spawn_sdf_model",
        SpawnModelRequest("box1", BOX.format(name="box", static="true"), "", _pose(2.0, 0.0, 0.25)),
    )
    assert res.success, res.status_message
    assert sim.gazebo.model_names == ["ground_plane", "racecar", "box1"]  # renamed to model_name
    assert _scan(sim)[AHEAD] == pytest.approx(2.0 - 0.25 - LASER[0], abs=2e-3)
    assert sim.bus.call("/gazebo/delete_model", DeleteModelRequest("box1")).success
    assert np.isinf(_scan(sim)[AHEAD])
    # a free box: pushable, seen where it stands, relative to a reference frame
    res = sim.bus.call(
        "/gazebo/spawn_sdf_model",
        SpawnModelRequest(
            "", BOX.format(name="crate", static="false"), "", _pose(1.5, 0.0, 0.25), "racecar::base_link"
        ),
    )
    assert res.success, res.status_message
    assert _scan(sim)[AHEAD] == pytest.approx(1.5 - 0.25 - LASER[0], abs=5e-3)
    assert _position(sim, "crate")[:2] == pytest.approx((1.5, 0.0), abs=1e-3)
    assert (
        sim.bus.call(
            "/gazebo/spawn_sdf_model", SpawnModelRequest("crate", BOX.format(name="x", static="true"), "", _pose(3, 3))
        ).success
        is False
    )


def test_delete_model_removes_a_cone_from_the_lidars_view():
    sim = _sim("cones", sensor_noise=False)  # the car at the origin faces the cones at x = 1 ... 5
    sim.run_until(0.5)  # landed: before, from 5 cm up, its laser (0.187 m) looks over the 0.17 m cones
    before = _scan(sim)[AHEAD]
    assert 0.5 < before < 1.0
    res = sim.bus.call("/gazebo/delete_model", DeleteModelRequest("cone_1"))
    assert res.success, res.status_message
    after = _scan(sim)[AHEAD]
    assert after == pytest.approx(before + 1.0, abs=0.02)  # the beam now reaches cone_2
    assert "cone_1" not in sim.gazebo.model_names and all(b.name != "cone_1::link" for b in sim.world.bodies)


# --- pause and reset ------------------------------------------------------------------------------------------------
def test_pause_stops_sim_time_and_odometry_unpause_resumes_it():
    sim = _sim(lidar=False)
    log = Log(sim, "/vesc/odom", "/clock")
    sim.run_until(0.5)
    sim.bus.call("/gazebo/pause_physics", EmptyRequest())
    assert sim.paused
    sim.run_until(1.0)
    assert sim.time == 0.5 and len(log["/vesc/odom"]) == 10 and len(log["/clock"]) == 50
    sim.bus.call("/gazebo/unpause_physics", EmptyRequest())
    sim.run_until(1.0)
    assert sim.time == 1.0 and len(log["/vesc/odom"]) == 20


def test_a_pause_during_an_event_stops_the_run_after_it():
    sim = _sim(lidar=False)
    sim.scheduler.at(300_000_000, lambda now: sim.bus.call("/gazebo/pause_physics", EmptyRequest()), "pause")
    sim.run_until(1.0)
    assert sim.time == 0.3


def test_reset_world_keeps_time_reset_simulation_resets_it():
    sim = _sim(lidar=False)
    ConstantCommand(sim.bus, sim.scheduler, speed=1.0, steering_angle=0.0)
    sim.run_until(1.0)
    assert _position(sim, "racecar")[0] > 0.5
    sim.bus.call("/gazebo/reset_world", EmptyRequest())
    assert sim.time == 1.0
    assert _position(sim, "racecar") == pytest.approx((0.0, 0.0, 0.05))
    sim.run_until(2.0)  # the command still arrives: the car drives again, time went on
    assert sim.time == 2.0 and _position(sim, "racecar")[0] > 0.5
    sim.bus.call("/gazebo/reset_simulation", EmptyRequest())
    assert sim.time == 0.0 and _position(sim, "racecar") == pytest.approx((0.0, 0.0, 0.05))


def test_reset_simulation_asked_during_an_event_happens_after_it():
    sim = _sim(lidar=False)
    stamps: list[int] = []
    sim.subscribe("/vesc/odom", lambda msg: stamps.append(_stamp(msg)))
    sim.scheduler.at(500_000_000, lambda now: sim.bus.call("/gazebo/reset_simulation", EmptyRequest()), "reset")
    sim.run_until(0.6)
    assert sim.time == 0.6
    assert stamps == [50_000_000 * k for k in range(1, 11)] + [50_000_000 * k for k in range(1, 13)]


def test_spawned_models_stay_through_a_reset_at_their_spawn_pose():
    sim = _sim("cones")
    urdf = expand_xacro(DEFAULT_XACRO)
    assert sim.bus.call("/gazebo/spawn_urdf_model", SpawnModelRequest("car2", urdf, "", _pose(0.0, 3.0, 0.05))).success
    assert sim.bus.call("/gazebo/delete_model", DeleteModelRequest("cone_5")).success
    sim.bus.call("/gazebo/set_model_state", SetModelStateRequest(ModelState("car2", _pose(2.0, -3.0))))
    sim.reset()
    assert _position(sim, "car2") == pytest.approx((0.0, 3.0, 0.05))
    assert "cone_5" not in sim.gazebo.model_names
    sim.run_until(0.5)
    assert sim.bus.count("/car2/vesc/odom") == 10  # after the reset its timers count from 0 like the others'


# --- recording -----------------------------------------------------------------------------------------------------
def test_model_and_link_states_are_recorded_and_read_back_by_rosbags(tmp_path):
    sim = _sim("cones", lidar=False)
    path = tmp_path / "run.mcap"
    recorder = sim.record(path)
    sim.run_until(0.5)
    recorder.close()
    with AnyReader([path], default_typestore=get_typestore(Stores.EMPTY)) as reader:
        types = {c.topic: c.msgtype for c in reader.connections}
        assert types[MODEL_STATES] == "gazebo_msgs/msg/ModelStates"
        assert types[LINK_STATES] == "gazebo_msgs/msg/LinkStates"
        connections = [c for c in reader.connections if c.topic == MODEL_STATES]
        rows = [(t, reader.deserialize(raw, c.msgtype)) for c, t, raw in reader.messages(connections=connections)]
    assert [t for t, _ in rows] == [10_000_000 * k for k in range(1, 51)]
    last = rows[-1][1]
    assert list(last.name) == ["ground_plane", "cone_1", "cone_2", "cone_3", "cone_4", "cone_5", "racecar"]
    assert last.pose[2].position.x == pytest.approx(2.0, abs=1e-3)


def test_recorded_link_states_follow_a_spawned_car(tmp_path):
    """The recorded states are read through array views kept with the MjData: a spawn (a new MjData) gives new ones,
    so the messages after it hold the spawned car's links where it was put, and the first car's where qpos has it."""
    sim = _sim(lidar=False)
    path = tmp_path / "run.mcap"
    with RunRecording(sim.bus, lambda: sim.time_ns, path):  # the run's recorder: it takes the states as rows
        sim.run_until(0.3)
        assert sim.gazebo._packers is not None  # the states go as MuJoCo's arrays
        urdf = expand_xacro(DEFAULT_XACRO, {})
        spawn = SpawnModelRequest("car2", urdf, "car2", _pose(0.0, 3.0, 0.05))
        res = sim.bus.call("/gazebo/spawn_urdf_model", spawn)
        assert res.success, res.status_message
        sim.run_until(0.6)
        assert sim.gazebo._packers is not None
        first = sim.data.qpos[:3].copy()
    with AnyReader([path], default_typestore=get_typestore(Stores.EMPTY)) as reader:
        connections = [c for c in reader.connections if c.topic == LINK_STATES]
        rows = [(t, reader.deserialize(raw, c.msgtype)) for c, t, raw in reader.messages(connections=connections)]
    assert [t for t, _ in rows] == [10_000_000 * k for k in range(1, 61)]
    before, last = rows[29][1], rows[-1][1]
    assert not any(name.startswith("car2::") for name in before.name)
    names = list(last.name)
    car2 = last.pose[names.index("car2::base_link")].position
    assert car2.y == pytest.approx(3.0, abs=0.05) and car2.x == pytest.approx(0.0, abs=0.05)
    mine = last.pose[names.index("racecar::base_link")].position
    assert (mine.x, mine.y, mine.z) == tuple(first)  # the live qpos, not the first MjData's frozen one
