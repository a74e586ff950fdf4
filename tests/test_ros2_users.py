"""ROS 2 nodes as users write them, against the bridge: plain rclpy scripts in the Jazzy wheels' venv, importing
nothing of racecar_sim.

- Every topic the sim publishes reaches a subscriber with the default profile (a plain depth of 10: reliable, as the
  F1TENTH labs and f1tenth_gym_ros write them) and one with `qos_profile_sensor_data` (best effort); latched topics
  also reach a late transient-local subscriber. The command topics take publishers of both profiles.
- /robot_description holds the URDF `racecar-sim describe --urdf` prints.
- A follow-the-gap node written as the F1TENTH lab template is (default QoS, /scan in, /drive out) drives the car along
  walker's course under `racecar-sim run --ros2 --topic-map f1tenth`, typed as the quick start (docs/ros2.md) types it.

Discovery stays on 127.0.0.1 (the bridge's and `ros2-env`'s Fast DDS profile), in a random ROS_DOMAIN_ID.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap
import time
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

from conftest import GL_MISSING
from racecar_sim.bridges.ros2 import Ros2Bridge, ros2_environment
from racecar_sim.runtime import Simulator

TELEOP = "/vesc/ackermann_cmd_mux/input/teleop"
NAVIGATION = "/vesc/ackermann_cmd_mux/input/navigation"

# A user's node: subscribes to each topic twice (default profile, sensor data), later once more transient-local where
# latched; then publishes commands with each profile, each with its own speed so the sim can tell them apart.
MATRIX = """
    import importlib, json, sys, time, rclpy
    from rclpy.node import Node
    from rclpy.qos import qos_profile_sensor_data, QoSProfile, DurabilityPolicy, ReliabilityPolicy

    topics, latched, commands = (json.loads(a) for a in sys.argv[1:4])
    def load(name):
        package, _, kind = name.split("/")
        return getattr(importlib.import_module(package + ".msg"), kind)

    rclpy.init()
    node = Node("qos_matrix")
    got = {f"{t} {p}": 0 for t in topics for p in ("default", "sensor_data")}
    volatile = [f"{t} {p}" for t in topics if t not in latched for p in ("default", "sensor_data")]
    text = {}
    def counter(key, topic):
        def on(msg):
            got[key] += 1
            if hasattr(msg, "data") and isinstance(msg.data, str):
                text[topic] = msg.data
        return on
    for topic, kind in topics.items():
        node.create_subscription(load(kind), topic, counter(f"{topic} default", topic), 10)
        node.create_subscription(load(kind), topic, counter(f"{topic} sensor_data", topic), qos_profile_sensor_data)
    end = time.monotonic() + 90
    while min(got[key] for key in volatile) < 3 and time.monotonic() < end:
        rclpy.spin_once(node, timeout_sec=0.05)
    late = Node("late_joiner")  # long after the latched messages went out
    tl = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL, reliability=ReliabilityPolicy.RELIABLE)
    for topic in latched:
        got[f"{topic} late"] = 0
        late.create_subscription(load(topics[topic]), topic, counter(f"{topic} late", topic), tl)
    end = time.monotonic() + 30
    while any(got[f"{t} late"] == 0 for t in latched) and time.monotonic() < end:
        rclpy.spin_once(late, timeout_sec=0.05)
    AckermannDriveStamped = load("ackermann_msgs/msg/AckermannDriveStamped")
    for topic in commands:
        for speed, qos in ((0.25, 10), (0.75, qos_profile_sensor_data)):
            pub = node.create_publisher(AckermannDriveStamped, topic, qos)
            end = time.monotonic() + 30
            while pub.get_subscription_count() == 0 and time.monotonic() < end:
                rclpy.spin_once(node, timeout_sec=0.05)
            cmd = AckermannDriveStamped()
            cmd.drive.speed = speed
            for _ in range(60):  # 3 s at 20 Hz, as a teleop node publishes
                pub.publish(cmd)
                rclpy.spin_once(node, timeout_sec=0.05)
    print(json.dumps({"got": got, "text": text}))
"""


def _run_sim_while(sim: Simulator, process: subprocess.Popen, limit: float) -> str:
    """Advance the sim, paced so that the ROS processes keep up on 2 cores, until the process exits; its output."""
    end = time.monotonic() + limit
    try:
        while process.poll() is None and time.monotonic() < end:
            sim.run_for(0.05)
            time.sleep(0.02)
        out, _ = process.communicate(timeout=20)
    finally:
        if process.poll() is None:
            process.kill()
    assert process.returncode == 0, out
    return out


def test_every_topic_reaches_default_and_sensor_data_subscribers_and_commands_take_both(jazzy, tmp_path) -> None:
    camera = not GL_MISSING
    topics = {
        "/scan": "sensor_msgs/msg/LaserScan",
        "/vesc/odom": "nav_msgs/msg/Odometry",
        "/tf": "tf2_msgs/msg/TFMessage",
        "/clock": "rosgraph_msgs/msg/Clock",
        "/tf_static": "tf2_msgs/msg/TFMessage",
        "/robot_description": "std_msgs/msg/String",
    }
    if camera:
        topics["/camera/zed/rgb/image_rect_color"] = "sensor_msgs/msg/Image"
        topics["/camera/zed/rgb/camera_info"] = "sensor_msgs/msg/CameraInfo"
    latched = ["/tf_static", "/robot_description"]
    script = tmp_path / "matrix.py"
    script.write_text(textwrap.dedent(MATRIX))
    heard: list[float] = []
    with Simulator(world="empty", camera=camera) as sim:
        sim.bus.subscribe(TELEOP, lambda msg: heard.append(msg.drive.speed))
        bridge = Ros2Bridge(sim)
        bridge.start()
        try:
            args = [json.dumps(topics), json.dumps(latched), json.dumps([TELEOP])]
            node = subprocess.Popen(
                [jazzy.python, str(script), *args],
                env=ros2_environment(jazzy, bridge.types),
                stdout=subprocess.PIPE,
                stderr=subprocess.STDOUT,
                text=True,
            )
            out = _run_sim_while(sim, node, limit=150)
        finally:
            bridge.close()
        urdf = sim.car.robot.urdf
    result = json.loads(out.strip().splitlines()[-1])
    assert "incompatible QoS" not in out, out
    # a volatile subscriber of a latched topic gets what is published after it joins (nothing here: it was published
    # once, at the start), as in ROS 2; it is matched all the same (no "incompatible QoS" above)
    wanted = [key for key in result["got"] if key.rsplit(" ", 1)[0] not in latched or key.endswith(" late")]
    missing = [key for key in wanted if result["got"][key] == 0]
    assert not missing and len(wanted) == 2 * len(topics) - len(latched), f"no messages on: {missing}"
    # every command profile reached the sim: the default publisher's 0.25 m/s and the sensor-data one's 0.75
    assert heard.count(0.25) >= 10 and heard.count(0.75) >= 10, heard
    assert _canonical(result["text"]["/robot_description"]) == _canonical(urdf)


def _canonical(urdf: str) -> str:
    return ET.canonicalize(urdf, strip_text=True)


def test_robot_description_is_the_urdf_describe_prints() -> None:
    printed = subprocess.run(
        [sys.executable, "-m", "racecar_sim", "describe", "--urdf"], capture_output=True, text=True, check=True
    ).stdout
    with Simulator(world="empty", camera=False) as sim:
        description = sim.bus.latched_messages()["/robot_description"].data
    assert _canonical(description) == _canonical(printed)
    assert ET.fromstring(description).get("name") == "racecar"


def test_each_car_of_a_fleet_has_its_own_robot_description() -> None:
    from racecar_sim.runtime import Car
    from racecar_sim.worlds import Spawn

    cars = [Car("car1", camera=False), Car("car2", camera=False, spawn=Spawn(0.0, 2.0, 0.05, 0.0))]
    with Simulator(world="empty", cars=cars) as sim:
        latched = sim.bus.latched_messages()
    assert "/robot_description" not in latched
    for name in ("car1", "car2"):
        assert ET.fromstring(latched[f"/{name}/robot_description"].data).find("link[@name='base_link']") is not None


# The F1TENTH lab template's reactive_node.py, as a student fills it in: rclpy, default QoS (a depth of 10).
FOLLOW_THE_GAP = '''
    import rclpy
    from rclpy.node import Node
    import numpy as np
    from sensor_msgs.msg import LaserScan
    from ackermann_msgs.msg import AckermannDriveStamped


    class ReactiveFollowGap(Node):
        """Implement Wall Following on the car: this is just a template, you are free to implement your own node!"""

        def __init__(self):
            super().__init__("reactive_node")
            lidarscan_topic = "/scan"
            drive_topic = "/drive"
            self.sub = self.create_subscription(LaserScan, lidarscan_topic, self.lidar_callback, 10)
            self.pub = self.create_publisher(AckermannDriveStamped, drive_topic, 10)

        def preprocess_lidar(self, ranges):
            ranges = np.nan_to_num(np.asarray(ranges), posinf=3.0)
            ranges = np.clip(ranges, 0.0, 3.0)
            return np.convolve(ranges, np.ones(5) / 5, mode="same")

        def find_max_gap(self, free_space_ranges):
            free = free_space_ranges > 0.0
            best, start = (0, 0), None
            for i, f in enumerate(np.append(free, False)):
                if f and start is None:
                    start = i
                elif not f and start is not None:
                    if i - start > best[1] - best[0]:
                        best = (start, i)
                    start = None
            return best

        def find_best_point(self, start_i, end_i, ranges):
            return (start_i + end_i) // 2

        def lidar_callback(self, data):
            ranges = self.preprocess_lidar(data.ranges)
            front = np.abs(data.angle_min + np.arange(len(ranges)) * data.angle_increment) < np.pi / 2
            ranges[~front] = 0.0
            closest = int(np.argmin(np.where(front, ranges, np.inf)))
            bubble = int(0.3 / max(ranges[closest], 0.1) / data.angle_increment)
            ranges[max(0, closest - bubble) : closest + bubble + 1] = 0.0
            start, end = self.find_max_gap(ranges)
            best = self.find_best_point(start, end, ranges)
            angle = data.angle_min + best * data.angle_increment
            drive = AckermannDriveStamped()
            drive.drive.steering_angle = float(np.clip(angle, -0.34, 0.34))
            drive.drive.speed = 1.5 if abs(angle) < 0.2 else 1.0
            self.pub.publish(drive)


    def main(args=None):
        rclpy.init(args=args)
        print("WallFollow Initialized")
        reactive_node = ReactiveFollowGap()
        rclpy.spin(reactive_node)
        reactive_node.destroy_node()
        rclpy.shutdown()


    if __name__ == "__main__":
        main()
'''

# What the F1TENTH launch's other nodes read, as they read it: the latched /map and the ego car's description for
# RViz (late, transient-local), odometry with a plain depth; and a teleop publishing /drive with sensor data's profile.
F1TENTH_READER = """
    import json, time, rclpy
    from rclpy.node import Node
    from rclpy.qos import qos_profile_sensor_data, QoSProfile, DurabilityPolicy, ReliabilityPolicy
    from nav_msgs.msg import OccupancyGrid, Odometry
    from std_msgs.msg import String
    from ackermann_msgs.msg import AckermannDriveStamped

    rclpy.init()
    node = Node("rviz_like")
    got = {"odom": 0, "odom_sensor_data": 0, "map": 0, "map_late": 0, "description_late": 0}
    def count(key):
        def on(msg):
            got[key] += 1
        return on
    node.create_subscription(Odometry, "/ego_racecar/odom", count("odom"), 10)
    node.create_subscription(Odometry, "/ego_racecar/odom", count("odom_sensor_data"), qos_profile_sensor_data)
    node.create_subscription(OccupancyGrid, "/map", count("map"), 10)  # matched; volatile: gets only later maps
    end = time.monotonic() + 120
    while (got["odom"] < 20 or got["odom_sensor_data"] < 20) and time.monotonic() < end:
        rclpy.spin_once(node, timeout_sec=0.05)
    tl = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL, reliability=ReliabilityPolicy.RELIABLE)
    node.create_subscription(OccupancyGrid, "/map", count("map_late"), tl)
    node.create_subscription(String, "/ego_robot_description", count("description_late"), tl)
    pub = node.create_publisher(AckermannDriveStamped, "/drive", qos_profile_sensor_data)
    cmd = AckermannDriveStamped()
    cmd.header.frame_id = "sensor_data_publisher"
    cmd.drive.speed = 1.0
    end = time.monotonic() + 30
    while (got["map_late"] == 0 or got["description_late"] == 0 or pub.get_subscription_count() == 0) \\
            and time.monotonic() < end:
        rclpy.spin_once(node, timeout_sec=0.05)
    for _ in range(10):
        pub.publish(cmd)
        rclpy.spin_once(node, timeout_sec=0.02)
    print(json.dumps(got))
"""


def _quick_start() -> list[str]:
    """The commands of the F1TENTH quick start (docs/ros2.md, linked from the README's recipes), comments dropped."""
    page = (Path(__file__).parents[1] / "docs" / "ros2.md").read_text()
    block = page.split("## F1TENTH quick start", 1)[1].split("```sh\n", 1)[1].split("```", 1)[0]
    return [line.split("  #", 1)[0].strip() for line in block.splitlines()]


def _output_once_stopped(process: subprocess.Popen, grace: float = 20.0) -> str:
    """What a node sent SIGTERM printed. rclpy's own shutdown can hang now and then (it did once in a CI run of this
    suite, in the F1TENTH node below, after the sim had exited); a user then kills the node, and so does this, keeping
    its output."""
    try:
        out, _ = process.communicate(timeout=grace)
    except subprocess.TimeoutExpired:
        process.kill()
        out, _ = process.communicate()
    return out


def test_f1tenth_lab_node_drives_walker_under_the_f1tenth_map_as_the_readme_says(jazzy, tmp_path) -> None:
    """The F1TENTH quick start (docs/ros2.md), as typed there: the sim, `eval "$(racecar-sim ros2-env)"`, the node.
    (Its first two lines, the install and `ros2-env --build`, are what the jazzy fixture has done.)"""
    install, build, run, env_line, node_line = _quick_start()
    assert install == 'pip install -e ".[ros2]"' and build.endswith("racecar-sim ros2-env --build")
    assert (
        run.endswith(" &") and env_line == 'eval "$(racecar-sim ros2-env)"' and node_line == "python reactive_node.py"
    )
    (tmp_path / "reactive_node.py").write_text(textwrap.dedent(FOLLOW_THE_GAP))
    (tmp_path / "rviz_like.py").write_text(textwrap.dedent(F1TENTH_READER))
    env = dict(os.environ, PATH=f"{Path(sys.executable).parent}{os.pathsep}{os.environ['PATH']}")
    popen = {"shell": True, "cwd": tmp_path, "env": env, "stdout": subprocess.PIPE, "stderr": subprocess.STDOUT}
    sim = subprocess.Popen(run.removesuffix(" &"), text=True, **popen)
    # `python` here is the test's ROS 2 venv's (a user's venv has rclpy itself)
    user = f"{env_line} && exec {jazzy.python} "
    nodes = [
        subprocess.Popen(user + node_line.split()[1], text=True, **popen),
        subprocess.Popen(user + "rviz_like.py", text=True, **popen),
    ]
    try:
        sim_out, _ = sim.communicate(timeout=240)
        reader_out, _ = nodes[1].communicate(timeout=60)
    finally:
        for process in (sim, *nodes):
            if process.poll() is None:
                process.terminate()
        node_out = _output_once_stopped(nodes[0])
    assert sim.returncode == 0, sim_out
    assert "WallFollow Initialized" in node_out and "incompatible QoS" not in node_out + reader_out, node_out
    (folder,) = (tmp_path / "runs").iterdir()  # runs/<date-time>/, as any run leaves
    summary = json.loads((folder / "summary.json").read_text())
    car = summary["cars"]["racecar"]
    assert summary["duration"] == pytest.approx(30.0) and car["distance"] >= 10.0, (car, sim_out)
    got = json.loads(reader_out.strip().splitlines()[-1])
    got.pop("map")  # volatile: it gets /map only if it joined before the map went out
    assert all(count > 0 for count in got.values()), got
    # /drive from a best-effort publisher entered the bus (the recording keeps the sim's names)
    from rosbags.highlevel import AnyReader

    with AnyReader([folder / "run.mcap"]) as reader:
        frames = [
            reader.deserialize(raw, conn.msgtype).header.frame_id
            for conn, _, raw in reader.messages([c for c in reader.connections if c.topic == NAVIGATION])
        ]
    assert "sensor_data_publisher" in frames and frames.count("") > 100  # and the lab node's own, at 40 Hz
