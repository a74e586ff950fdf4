"""Sensors come from the description: a user's xacro that adds an IMU, a rear-facing second laser and a depth camera to
the original car gets each of them, at its declared rate, frame and topic, measuring what physics and geometry say.

Expectations come from outside the sensors: gravity for the IMU at rest, the odometry's yaw rate on a circle, and the
URDF chain (link sites in the compiled model) for where a wall is seen."""

from __future__ import annotations

import math
import textwrap

import numpy as np
import pytest

from conftest import Log
from racecar_sim import Simulator
from racecar_sim.core.errors import RenderingError
from racecar_sim.drivers import ConstantCommand
from racecar_sim.worlds import Spawn

IMU_TOPIC = "/racecar/imu/data"  # gazebo_ros_imu_sensor: <topicName> under the model's name when no <robotNamespace>
REAR_SCAN = "/scan_rear"
DEPTH = "/depth/depth/image_raw"
POINTS = "/depth/depth/points"
DEPTH_RGB = "/depth/rgb/image_raw"
WALL_AHEAD, WALL_BEHIND = 3.0, -2.0  # x of the walls' near faces in the test world

USER_XACRO = """\
<?xml version="1.0"?>
<robot name="racecar" xmlns:xacro="http://www.ros.org/wiki/xacro">
  <xacro:include filename="$(find racecar_description)/urdf/racecar.xacro"/>

  <link name="imu_link"/>
  <joint name="imu_joint" type="fixed">
    <parent link="chassis"/><child link="imu_link"/><origin xyz="0.05 0.02 0.06" rpy="0 0 0"/>
  </joint>
  <gazebo reference="imu_link">
    <sensor type="imu" name="imu_sensor">
      <always_on>true</always_on>
      <update_rate>100</update_rate>
      <plugin name="imu_plugin" filename="libgazebo_ros_imu_sensor.so">
        <topicName>imu/data</topicName>
        <frameName>imu_link</frameName>
        <updateRateHZ>100.0</updateRateHZ>
        <gaussianNoise>0.0</gaussianNoise>
      </plugin>
    </sensor>
  </gazebo>

  <link name="rear_laser"/>
  <joint name="rear_laser_joint" type="fixed">
    <parent link="chassis"/><child link="rear_laser"/><origin xyz="-0.12 0 0.12" rpy="0 0 3.141592653589793"/>
  </joint>
  <gazebo reference="rear_laser">
    <sensor type="ray" name="rear_hokuyo">
      <update_rate>20</update_rate>
      <ray>
        <scan><horizontal><samples>181</samples><resolution>1</resolution>
          <min_angle>-1.5707963</min_angle><max_angle>1.5707963</max_angle></horizontal></scan>
        <range><min>0.1</min><max>10.0</max></range>
      </ray>
      <plugin name="rear_laser_controller" filename="libgazebo_ros_laser.so">
        <topicName>/scan_rear</topicName>
        <frameName>rear_laser</frameName>
      </plugin>
    </sensor>
  </gazebo>

  <link name="depth_link"/>
  <joint name="depth_joint" type="fixed">
    <parent link="chassis"/><child link="depth_link"/><origin xyz="0.2 0 0.15" rpy="0 0 0"/>
  </joint>
  <gazebo reference="depth_link">
    <sensor type="depth" name="depth_camera">
      <update_rate>10</update_rate>
      <camera>
        <horizontal_fov>1.047</horizontal_fov>
        <image><width>160</width><height>120</height></image>
        <clip><near>0.05</near><far>8.0</far></clip>
      </camera>
      <plugin name="kinect" filename="libgazebo_ros_openni_kinect.so">
        <cameraName>depth</cameraName>
        <imageTopicName>rgb/image_raw</imageTopicName>
        <cameraInfoTopicName>rgb/camera_info</cameraInfoTopicName>
        <depthImageTopicName>depth/image_raw</depthImageTopicName>
        <depthImageCameraInfoTopicName>depth/camera_info</depthImageCameraInfoTopicName>
        <pointCloudTopicName>depth/points</pointCloudTopicName>
        <frameName>depth_link</frameName>
        <pointCloudCutoff>0.1</pointCloudCutoff>
        <pointCloudCutoffMax>8.0</pointCloudCutoffMax>
      </plugin>
    </sensor>
  </gazebo>
</robot>
"""

WALLS_WORLD = f"""\
<?xml version="1.0"?>
<sdf version="1.6"><world name="walls">
  <include><uri>model://ground_plane</uri></include>
  <model name="ahead"><static>true</static><pose>{WALL_AHEAD + 0.1} 0 1 0 0 0</pose><link name="link">
    <collision name="c"><geometry><box><size>0.2 8 2</size></box></geometry></collision>
    <visual name="v"><geometry><box><size>0.2 8 2</size></box></geometry></visual></link></model>
  <model name="behind"><static>true</static><pose>{WALL_BEHIND - 0.1} 0 1 0 0 0</pose><link name="link">
    <collision name="c"><geometry><box><size>0.2 8 2</size></box></geometry></collision>
    <visual name="v"><geometry><box><size>0.2 8 2</size></box></geometry></visual></link></model>
</world></sdf>
"""


@pytest.fixture
def user_xacro(tmp_path):
    path = tmp_path / "my_car.xacro"
    path.write_text(USER_XACRO)
    return path


def stamp(msg) -> float:
    return msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9


def test_the_imu_reads_gravity_at_rest_and_the_odometrys_yaw_rate_on_a_circle(user_xacro):
    with Simulator(world="empty", xacro=user_xacro, camera=False, lidar=False, seed=1) as sim:
        log = Log(sim, IMU_TOPIC, "/vesc/odom")
        sim.run_until(2.0)
        imu = log[IMU_TOPIC]
        assert len(imu) == 200  # 100 Hz of sim time, exactly
        assert {m.header.frame_id for m in imu} == {"imu_link"}
        settled = [m for m in imu if stamp(m) > 1.0]
        up = np.mean([m.linear_acceleration.z for m in settled])
        assert up == pytest.approx(-sim.model.opt.gravity[2], abs=1e-3)  # the world's gravity, read upward
        assert up == pytest.approx(9.81, abs=0.05)
        assert max(abs(m.linear_acceleration.x) + abs(m.linear_acceleration.y) for m in settled) < 0.05
        ConstantCommand(sim.bus, sim.scheduler, 1.0, 0.3)
        sim.run_until(8.0)
    rates = {round(stamp(m), 3): m.angular_velocity.z for m in log[IMU_TOPIC]}
    odom = [(round(stamp(m), 3), m.twist.twist.angular.z) for m in log["/vesc/odom"] if stamp(m) > 5.0]
    assert len(odom) > 50
    for t, yaw_rate in odom:  # the same instants: 20 Hz odometry stamps are 100 Hz IMU stamps too
        assert abs(yaw_rate) > 0.5
        assert rates[t] == pytest.approx(yaw_rate, rel=0.02)


def test_a_second_rear_facing_laser_sees_the_wall_behind_the_car(user_xacro, tmp_path):
    world = tmp_path / "walls.world"
    world.write_text(WALLS_WORLD)
    with Simulator(world=str(world), xacro=user_xacro, camera=False, seed=2, spawn=Spawn(0, 0, 0.05, 0)) as sim:
        log = Log(sim, "/scan", REAR_SCAN)
        sim.run_until(1.0)
        origin = sim.data.site("rear_laser").xpos.copy()  # the URDF frame of the rear laser, in the world
    front, rear = log["/scan"], log[REAR_SCAN]
    assert len(front) == 40 and len(rear) == 20  # each laser at its own <update_rate>
    assert {m.header.frame_id for m in rear} == {"rear_laser"} and {m.header.frame_id for m in front} == {"laser"}
    scan = rear[-1]
    assert len(scan.ranges) == 181 and scan.angle_min == pytest.approx(-1.5707963)
    middle = float(scan.ranges[90])  # angle 0 of a laser turned by pi: straight back
    assert middle == pytest.approx(origin[0] - WALL_BEHIND, abs=0.01)  # no <noise> declared: exact
    # the front laser still sees the wall ahead
    ahead = float(front[-1].ranges[len(front[-1].ranges) // 2])
    assert ahead == pytest.approx(WALL_AHEAD - sim.data.site("laser").xpos[0], abs=0.04)


def test_a_depth_camera_gives_the_distance_to_the_wall_ahead(user_xacro, tmp_path):
    world = tmp_path / "walls.world"
    world.write_text(WALLS_WORLD)
    try:
        sim = Simulator(
            world=str(world), xacro=user_xacro, camera=True, lidar=False, seed=3, spawn=Spawn(0, 0, 0.05, 0)
        )
    except RenderingError as exc:
        pytest.skip(str(exc))
    with sim:
        log = Log(sim, DEPTH, POINTS, DEPTH_RGB, "/depth/depth/camera_info")
        sim.run_until(1.0)
        camera_x = sim.data.site("depth_link").xpos[0]
    depth_images = log[DEPTH]
    assert len(depth_images) == 10 and len(log[DEPTH_RGB]) == 10  # 10 Hz
    image = depth_images[-1]
    assert (image.encoding, image.width, image.height, image.header.frame_id) == ("32FC1", 160, 120, "depth_link")
    depth = np.frombuffer(image.data, "<f4").reshape(120, 160)
    assert not np.isnan(depth).any()
    expected = WALL_AHEAD - camera_x
    assert float(depth[60, 80]) == pytest.approx(expected, abs=0.02)
    assert float(depth[59, 79]) == pytest.approx(expected, abs=0.02)
    cloud = log[POINTS][-1]
    points = np.frombuffer(cloud.data, "<f4").reshape(-1, 3)
    assert cloud.width == len(points) > 1000 and cloud.is_dense
    centre = points[np.argmin(np.hypot(points[:, 0], points[:, 1]))]
    assert centre[2] == pytest.approx(expected, abs=0.02) and math.hypot(centre[0], centre[1]) < 0.05
    info = log["/depth/depth/camera_info"][-1]
    assert info.width == 160 and info.k[0] == pytest.approx(80 / math.tan(1.047 / 2), rel=1e-6)


def test_the_original_car_gets_exactly_todays_sensors():
    with Simulator(world="empty", camera=False) as sim:
        kinds = [type(node).__name__ for node in sim.car.sensors]
    assert kinds == ["LidarPublisher"]


def test_an_unknown_plugin_is_a_warning_naming_it_and_the_file(tmp_path, caplog):
    path = tmp_path / "odd.xacro"
    path.write_text(
        USER_XACRO.replace(
            "</robot>",
            textwrap.dedent("""\
        <gazebo><plugin name="mystery" filename="libmystery_plugin.so"><x>1</x></plugin></gazebo>
        </robot>"""),
        )
    )
    with caplog.at_level("WARNING", logger="racecar_sim"):
        with Simulator(world="empty", xacro=path, camera=False, lidar=False):
            pass
    lines = [r.getMessage() for r in caplog.records if "libmystery_plugin.so" in r.getMessage()]
    assert len(lines) == 1 and str(path) in lines[0]


def test_sensors_are_switched_off_in_one_place_by_switch_type_or_name(user_xacro):
    with Simulator(world="empty", xacro=user_xacro, camera=False, sensors_off=("imu", "rear_hokuyo"), seed=4) as sim:
        kinds = [(type(node).__name__, getattr(node, "topic", None)) for node in sim.car.sensors]
    assert kinds == [("LidarPublisher", "/scan")]  # no IMU, no rear laser, no depth camera (the camera switch)
    with Simulator(world="empty", xacro=user_xacro, lidar=False, camera=False, seed=4) as sim:
        assert [type(node).__name__ for node in sim.car.sensors] == ["ImuPublisher"]
        assert sim.car.lidar is None and not sim.car.has_lidar


def test_the_cli_leaves_out_a_sensor_named_by_no_sensor(user_xacro, tmp_path):
    import subprocess
    import sys

    from mcap.reader import make_reader

    out = tmp_path / "run"
    result = subprocess.run(
        [
            sys.executable,
            "-m",
            "racecar_sim",
            "run",
            "--world",
            "empty",
            "--xacro",
            str(user_xacro),
            "--driver",
            "constant",
            "--duration",
            "1",
            "--no-camera",
            "--no-sensor",
            "rear_hokuyo",
            "--out",
            str(out),
            "--no-video",
            "--no-summary",
        ],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert result.returncode == 0, result.stderr
    with open(out / "run.mcap", "rb") as f:
        topics = {channel.topic for channel in make_reader(f).get_summary().channels.values()}
    assert "/scan" in topics and IMU_TOPIC in topics and REAR_SCAN not in topics and DEPTH not in topics
