"""The ROS 1 bridge against real ROS 1 (Debian's roscore, rospy, rostopic, rosservice, rosbag).

Each test's ROS processes run under the ROS interpreter with the PYTHONPATH `racecar-sim ros-env` prints; a roscore
on a free port of 127.0.0.1 is started for the module. Skipped only where ROS 1 is not installed.
"""

from __future__ import annotations

import os
import signal
import subprocess
import textwrap
import time
import xmlrpc.client
from pathlib import Path

import numpy as np
import pytest

from racecar_sim.bridges.ros1 import RosBridge, message_path, ros_available, ros_python
from racecar_sim.bridges.ros1.environment import ros_environment
from racecar_sim.bridges.ros1.master import Master
from racecar_sim.runtime import Simulator

pytestmark = pytest.mark.skipif(
    not (Path("/usr/bin/roscore").exists() and ros_available()),
    reason="ROS 1 is not installed (apt-get install ros-core python3-rospy ...)",
)
PACE = 0.02  # s of wall time slept per 0.05 s of sim time: ROS processes keep up on a 2-core machine
NAVIGATION = "/vesc/ackermann_cmd_mux/input/navigation"


@pytest.fixture(scope="module")
def master() -> Master:
    """A roscore on a free port of 127.0.0.1 for this module; ROS_MASTER_URI points at it."""
    core = Master(None, ros_environment(None, None), port=None)
    old = os.environ.get("ROS_MASTER_URI")
    os.environ["ROS_MASTER_URI"] = core.uri
    yield core
    core.close()
    if old is None:
        os.environ.pop("ROS_MASTER_URI", None)
    else:
        os.environ["ROS_MASTER_URI"] = old


@pytest.fixture
def ros_env(master: Master) -> dict[str, str]:
    """The environment of a user's ROS process, as `eval "$(racecar-sim ros-env)"` sets it."""
    return ros_environment(master.uri, message_path())


def bridged(master: Master, **sim_options) -> tuple[Simulator, RosBridge]:
    sim = Simulator(world="empty", camera=False, **sim_options)
    bridge = RosBridge(sim, master.uri)
    bridge.start()
    return sim, bridge


def run_while(
    sim: Simulator, processes: list[subprocess.Popen], limit: float = 60.0, sim_limit: float | None = None
) -> None:
    """Advance the sim (paced) until every process exits, `limit` wall seconds pass, or sim time reaches sim_limit."""
    end = time.monotonic() + limit
    while any(p.poll() is None for p in processes) and time.monotonic() < end:
        if sim_limit is not None and sim.time >= sim_limit:
            break
        sim.run_for(0.05)
        time.sleep(PACE)


def ros_script(tmp_path: Path, name: str, body: str, env: dict[str, str], *args: str) -> subprocess.Popen:
    path = tmp_path / name
    path.write_text(textwrap.dedent(body))
    return subprocess.Popen([ros_python(), str(path), *args], env=env, stdout=subprocess.PIPE, text=True)


def wait_for_service(bridge: RosBridge, name: str, limit: float = 30.0) -> None:
    """Spin until the ROS side has registered service `name` with the master (it does so a moment after start)."""
    master = xmlrpc.client.ServerProxy(bridge.master_uri)
    end = time.monotonic() + limit
    while master.lookupService("/test", name)[0] != 1:
        assert time.monotonic() < end, f"{name} never registered"
        bridge.spin_once(0.05)


def wait_connected(bridge: RosBridge, topic: str, sim: Simulator, limit: float = 30.0) -> None:
    """Run the sim in small steps until a ROS node subscribes to `topic` (its first message advertises it)."""
    end = time.monotonic() + limit
    while time.monotonic() < end:
        out = bridge._out.get(topic)
        if out is not None and out.connections > 0:
            return
        sim.run_for(0.01)
        time.sleep(0.02)
    raise AssertionError(f"no ROS subscriber on {topic}")


def test_scan_at_40_hz_of_sim_time_with_ros1_types(master: Master, ros_env: dict, tmp_path: Path) -> None:
    sub = ros_script(
        tmp_path,
        "scan_sub.py",
        """
        import rospy
        from sensor_msgs.msg import LaserScan
        got = []
        def on_scan(msg):
            got.append((msg._type, msg.header.seq, msg.header.stamp.to_nsec(), msg.header.frame_id, len(msg.ranges)))
        rospy.init_node("scan_counter")
        rospy.Subscriber("/scan", LaserScan, on_scan, queue_size=1000)
        while len(got) < 60 and not rospy.is_shutdown():
            rospy.sleep(rospy.Duration(0, 10_000_000))
        for item in got:
            print(*item)
    """,
        ros_env,
    )
    sim, bridge = bridged(master)
    try:
        run_while(sim, [sub])
        lines = [line.split() for line in sub.communicate(timeout=10)[0].splitlines()]
    finally:
        bridge.close()
        sim.close()
    assert len(lines) >= 60
    types = {line[0] for line in lines}
    seqs = [int(line[1]) for line in lines]
    stamps = np.array([int(line[2]) for line in lines]) / 1e9
    assert types == {"sensor_msgs/LaserScan"}
    assert {line[3] for line in lines} == {"laser"}
    assert np.all(np.diff(seqs) == 1)  # one seq per message, none lost
    rate = (len(stamps) - 1) / (stamps[-1] - stamps[0])
    assert rate == pytest.approx(40.0, rel=0.01)
    assert stamps[-1] <= sim.time


def test_rostopic_pub_of_ackermann_drives_the_car(master: Master, ros_env: dict) -> None:
    sim, bridge = bridged(master)
    odom = []
    sim.subscribe("/vesc/odom", odom.append)
    pub = subprocess.Popen(
        [
            "rostopic",
            "pub",
            "-r",
            "20",
            NAVIGATION,
            "ackermann_msgs/AckermannDriveStamped",
            "{drive: {speed: 1.0, steering_angle: 0.0}}",
        ],
        env=ros_env,
        stdout=subprocess.DEVNULL,
    )
    try:
        end = time.monotonic() + 30
        while bridge.received == 0 and time.monotonic() < end:  # rostopic connects to the bridge
            sim.run_for(0.01)
            time.sleep(0.02)
        run_while(sim, [pub], limit=60, sim_limit=sim.time + 3.0)
    finally:
        pub.send_signal(signal.SIGINT)
        pub.wait(10)
        bridge.close()
        sim.close()
    assert bridge.received > 10
    x = odom[-1].pose.pose.position.x
    assert x > 1.5, f"the car moved only {x:.2f} m in 3 s of sim time at 1 m/s"
    assert abs(odom[-1].pose.pose.position.y) < 0.2
    assert odom[-1].twist.twist.linear.x == pytest.approx(1.0, abs=0.15)


def test_rosbag_record_counts_match_sim_time(master: Master, ros_env: dict, tmp_path: Path) -> None:
    bag = tmp_path / "run.bag"
    sim, bridge = bridged(master)
    record = subprocess.Popen(
        ["rosbag", "record", "-O", str(bag), "/scan", "/vesc/odom"],
        env=ros_env,
        stdout=subprocess.DEVNULL,
        start_new_session=True,
    )
    try:
        wait_connected(bridge, "/scan", sim)
        wait_connected(bridge, "/vesc/odom", sim)
        start = sim.time
        run_while(sim, [record], limit=60, sim_limit=start + 2.0)
        end = sim.time
        time.sleep(1.0)  # rosbag writes what is in flight
    finally:
        os.killpg(record.pid, signal.SIGINT)
        record.wait(20)
        bridge.close()
        sim.close()
    reader = subprocess.run(
        [
            ros_python(),
            "-c",
            textwrap.dedent("""
        import sys, rosbag
        with rosbag.Bag(sys.argv[1]) as bag:
            for topic, msg, t in bag.read_messages():
                print(topic, msg._type, msg.header.stamp.to_nsec())
    """),
            str(bag),
        ],
        env=ros_env,
        capture_output=True,
        text=True,
        check=True,
    )
    rows = [line.split() for line in reader.stdout.splitlines()]
    scans = [int(r[2]) / 1e9 for r in rows if r[0] == "/scan"]
    odoms = [int(r[2]) / 1e9 for r in rows if r[0] == "/vesc/odom"]
    assert {r[1] for r in rows if r[0] == "/scan"} == {"sensor_msgs/LaserScan"}
    assert {r[1] for r in rows if r[0] == "/vesc/odom"} == {"nav_msgs/Odometry"}

    def in_window(stamps: list[float]) -> int:
        return sum(start + 1e-9 < s <= end + 1e-9 for s in stamps)

    assert in_window(scans) == pytest.approx(40 * (end - start), abs=2)
    assert in_window(odoms) == pytest.approx(20 * (end - start), abs=2)


def test_rosservice_get_model_state_answers_with_the_pose(master: Master, ros_env: dict) -> None:
    sim, bridge = bridged(master)
    try:
        sim.run_for(0.5)
        wait_for_service(bridge, "/gazebo/get_model_state")
        call = subprocess.Popen(
            ["rosservice", "call", "/gazebo/get_model_state", "{model_name: racecar}"],
            env=ros_env,
            stdout=subprocess.PIPE,
            text=True,
        )
        while call.poll() is None:  # the sim answers only while it runs (or spins)
            bridge.spin_once(0.05)
        out = call.communicate()[0]
        expected = sim.gazebo.get_model_state(
            __import__("racecar_sim.msgs.gazebo_msgs", fromlist=["x"]).GetModelStateRequest("racecar")
        )
    finally:
        bridge.close()
        sim.close()
    assert call.returncode == 0
    assert "success: True" in out
    z = float(out.split("position:")[1].split("z:")[1].split()[0])
    assert z == pytest.approx(expected.pose.position.z, abs=1e-6)
    secs = int(out.split("secs:")[1].split()[0])
    assert secs == 0  # a sim-time stamp (0.5 s), not wall time


def test_sim_time_node_follows_clock(master: Master, ros_env: dict, tmp_path: Path) -> None:
    node = ros_script(
        tmp_path,
        "clock_node.py",
        """
        import rospy
        from rosgraph_msgs.msg import Clock
        rospy.init_node("sim_time_node")
        seen = []
        rospy.Subscriber("/clock", Clock, lambda m: seen.append(m.clock))
        while len(seen) < 30 and not rospy.is_shutdown():
            rospy.sleep(0.01)  # sim time: returns as the sim's clock runs
        now = rospy.Time.now()
        print(rospy.get_param("/use_sim_time"), seen[-1].to_sec(), now.to_sec())
    """,
        ros_env,
    )
    sim, bridge = bridged(master)
    try:
        run_while(sim, [node])
        use_sim_time, clock, now = node.communicate(timeout=10)[0].split()
    finally:
        bridge.close()
        sim.close()
    assert use_sim_time == "True"
    # sim seconds, not the wall clock's 1.7e9; rospy's own /clock subscription and the node's are separate
    # connections, so either may be a tick ahead of the other
    assert 0.0 < float(now) <= sim.time and abs(float(now) - float(clock)) <= 0.1
    assert float(now) - float(clock) < 0.1


def test_servo_commands_as_a_ros_node_drives_the_car(master: Master, ros_env: dict, tmp_path: Path) -> None:
    from racecar_sim.msgs import AckermannDrive, AckermannDriveStamped
    from racecar_sim.runtime.car import Car, CarNodes

    # racecar_control's servo_commands.py: wheel speeds from the speed, both hinges from the steering angle
    servo = ros_script(
        tmp_path,
        "servo_commands.py",
        """
        import rospy
        from std_msgs.msg import Float64
        from ackermann_msgs.msg import AckermannDriveStamped
        rospy.init_node("servo_commands")
        wheels = ["left_rear_wheel", "right_rear_wheel", "left_front_wheel", "right_front_wheel"]
        pubs = {w: rospy.Publisher("/racecar/%s_velocity_controller/command" % w, Float64, queue_size=1)
                for w in wheels}
        hinges = {h: rospy.Publisher("/racecar/%s_steering_hinge_position_controller/command" % h, Float64,
                                     queue_size=1) for h in ("left", "right")}
        def on_drive(data):
            throttle = data.drive.speed / 0.1
            for pub in pubs.values():
                pub.publish(throttle)
            for pub in hinges.values():
                pub.publish(data.drive.steering_angle)
        rospy.Subscriber("/vesc/low_level/ackermann_cmd_mux/output", AckermannDriveStamped, on_drive)
        rospy.spin()
    """,
        ros_env,
    )
    sim = Simulator(world="empty", cars=[Car("", camera=False, nodes=CarNodes(servo_input=None))])
    bridge = RosBridge(sim, master.uri)
    bridge.start()
    assert sim.car.servo is None
    command = AckermannDriveStamped(drive=AckermannDrive(speed=1.0))
    sim.scheduler.every(20.0, lambda t: sim.publish(NAVIGATION, command), "navigation")
    try:
        wait_connected(bridge, "/vesc/low_level/ackermann_cmd_mux/output", sim)
        start_t = sim.time
        end = time.monotonic() + 60
        while sim.time < start_t + 3.0 and time.monotonic() < end:
            sim.run_for(0.05)
            time.sleep(PACE)
        x = sim.gazebo.get_model_state(
            __import__("racecar_sim.msgs.gazebo_msgs", fromlist=["x"]).GetModelStateRequest("racecar")
        ).pose.position.x
    finally:
        servo.send_signal(signal.SIGINT)
        servo.wait(10)
        bridge.close()
        sim.close()
    assert bridge.received > 50  # six commands per mux output
    # speed / 0.1 rad/s on 0.05 m wheels, as the original node did: about half the commanded ground speed
    assert x > 0.8, f"the car moved only {x:.2f} m in 3 s driven by the ROS servo node"
