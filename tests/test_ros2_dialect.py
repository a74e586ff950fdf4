"""The ROS 2 dialect of the plugins, as a Humble user's description writes them: each block publishes on the topics
and in the frame gazebo_ros for ROS 2 would give it (the node named after the plugin, in <ros><namespace>, `~/out`
under the node unless <remapping> says otherwise, <camera_name>/image_raw under the namespace, <frame_name> or the
link Gazebo attaches the sensor to). The expected names are written out here by those rules."""

from __future__ import annotations

import math

import numpy as np
import pytest

from conftest import Log
from racecar_sim import Simulator
from racecar_sim.core.errors import RenderingError
from racecar_sim.msgs.sensor_msgs import Imu, LaserScan, PointCloud2, Range
from racecar_sim.runtime import plugins
from racecar_sim.sensors.ros2_dialect import Ros2Node
from racecar_sim.worlds import Spawn

FLT_MAX = 3.4028234663852886e38


def _link(name: str, xyz: str, yaw: float = 0.0) -> str:
    return f"""
  <link name="{name}"/>
  <joint name="{name}_joint" type="fixed">
    <parent link="chassis"/><child link="{name}"/><origin xyz="{xyz}" rpy="0 0 {yaw}"/>
  </joint>"""


RAY = (
    "<ray><scan><horizontal><samples>{n}</samples><resolution>1</resolution><min_angle>{lo}</min_angle>"
    "<max_angle>{hi}</max_angle></horizontal></scan><range><min>0.1</min><max>{max}</max></range></ray>"
)

USER_XACRO = f"""\
<?xml version="1.0"?>
<robot name="racecar" xmlns:xacro="http://www.ros.org/wiki/xacro">
  <xacro:include filename="$(find racecar_description)/urdf/racecar.xacro"/>
  {_link("rear_laser", "-0.12 0 0.12", math.pi)}
  <gazebo reference="rear_laser">
    <sensor type="ray" name="rear_lidar">
      <update_rate>10</update_rate>
      {RAY.format(n=91, lo=-0.7853981, hi=0.7853981, max=12.0)}
      <plugin name="laser_2d" filename="libgazebo_ros_ray_sensor.so">
        <ros><namespace>/demo</namespace><remapping>~/out:=scan</remapping></ros>
        <output_type>sensor_msgs/LaserScan</output_type>
        <frame_name>rear_laser</frame_name>
      </plugin>
    </sensor>
  </gazebo>
  {_link("sonar_link", "0 0.1 0.05", math.pi / 2)}
  <gazebo reference="sonar_link">
    <sensor type="ray" name="side_sonar">
      <update_rate>5</update_rate>
      {RAY.format(n=3, lo=-0.1, hi=0.1, max=1.5)}
      <plugin name="sonar" filename="libgazebo_ros_ray_sensor.so">
        <output_type>sensor_msgs/Range</output_type>
      </plugin>
    </sensor>
  </gazebo>
  {_link("imu_link", "0.05 0 0.06")}
  <gazebo reference="imu_link">
    <sensor type="imu" name="imu_sensor">
      <update_rate>50</update_rate>
      <plugin name="imu_plugin" filename="libgazebo_ros_imu_sensor.so">
        <ros><namespace>/demo</namespace><argument>~/out:=imu</argument></ros>
        <frame_name>imu_link</frame_name>
      </plugin>
    </sensor>
  </gazebo>
  {_link("cloud_link", "0.1 0 0.1")}
  <gazebo reference="cloud_link">
    <sensor type="ray" name="cloud">
      <update_rate>10</update_rate>
      {RAY.format(n=10, lo=-0.1, hi=0.1, max=5.0)}
      <plugin name="cloud" filename="libgazebo_ros_ray_sensor.so"><ros><namespace>/demo</namespace></ros></plugin>
    </sensor>
    <sensor type="ray" name="odd">
      <update_rate>10</update_rate>
      {RAY.format(n=3, lo=-0.1, hi=0.1, max=5.0)}
      <plugin name="odd" filename="libgazebo_ros_ray_sensor.so"><output_type>sensor_msgs/Foo</output_type></plugin>
    </sensor>
  </gazebo>
</robot>
"""

CAMERA_XACRO = f"""\
<?xml version="1.0"?>
<robot name="racecar" xmlns:xacro="http://www.ros.org/wiki/xacro">
  <xacro:include filename="$(find racecar_description)/urdf/racecar.xacro"/>
  {_link("front_cam", "0.2 0 0.1")}
  <gazebo reference="front_cam">
    <sensor type="camera" name="front_camera">
      <update_rate>10</update_rate>
      <camera><horizontal_fov>1.0</horizontal_fov><image><width>64</width><height>48</height><format>R8G8B8</format>
        </image><clip><near>0.05</near><far>20</far></clip></camera>
      <plugin name="front_camera_driver" filename="libgazebo_ros_camera.so">
        <ros><namespace>/demo</namespace></ros><camera_name>front</camera_name><frame_name>front_cam</frame_name>
      </plugin>
    </sensor>
    <sensor type="depth" name="depth_cam">
      <update_rate>5</update_rate>
      <camera><horizontal_fov>1.0</horizontal_fov><image><width>32</width><height>24</height></image>
        <clip><near>0.05</near><far>8</far></clip></camera>
      <plugin name="depth_driver" filename="libgazebo_ros_camera.so"><ros><namespace>/demo</namespace></ros>
        <min_depth>0.1</min_depth></plugin>
    </sensor>
  </gazebo>
</robot>
"""


def test_the_node_rules():
    """rcl's resolution, as gazebo_ros::Node sets the node up: `~` under the node, relative under the namespace, a
    rule applied to the name it resolves to."""
    node = Ros2Node("laser_2d", "/demo", (("~/out", "scan"),))
    assert node.topic("~/out") == "/demo/scan" and node.topic("other") == "/demo/other" and node.topic("/x") == "/x"
    assert Ros2Node("sonar", "/", ()).topic("~/out") == "/sonar/out"
    assert Ros2Node("cam", "/demo", (("out", "x"),)).topic("~/out") == "/demo/cam/out"  # `out` is not `~/out`


def test_each_ros2_block_publishes_where_humble_gazebo_ros_would(tmp_path, caplog):
    path = tmp_path / "ros2.xacro"
    path.write_text(USER_XACRO)
    with caplog.at_level("WARNING", logger="racecar_sim"):
        sim = Simulator(world="empty", xacro=path, camera=False, seed=4, spawn=Spawn(0, 0, 0.05, 0))
    with sim:
        log = Log(sim, "/demo/scan", "/sonar/out", "/demo/imu", "/scan", "/demo/cloud/out")
        sim.run_until(1.0)
        kinds = [p.kind.name for p in sim.car._planned[1]]
    assert kinds == [
        "laser",
        "laser",
        "range",
        "imu",
        "ray_cloud",
    ]  # the Hokuyo, then the ROS 2 blocks by <output_type>
    scan: LaserScan = log["/demo/scan"][-1]
    assert len(log["/demo/scan"]) == 10 and scan.header.frame_id == "rear_laser" and len(scan.ranges) == 91
    sonar: Range = log["/sonar/out"][-1]
    assert len(log["/sonar/out"]) == 5
    assert sonar.header.frame_id == "base_link"  # no <frame_name>: the link Gazebo lumped sonar_link into
    assert sonar.radiation_type == Range.INFRARED and sonar.field_of_view == pytest.approx(0.2)
    assert sonar.range == FLT_MAX  # nothing in 1.5 m: gazebo_ros's conversion leaves its first value
    imu: Imu = log["/demo/imu"][-1]
    assert len(log["/demo/imu"]) == 50 and imu.header.frame_id == "imu_link"
    assert imu.linear_acceleration.z == pytest.approx(9.81, abs=0.1)
    assert len(log["/scan"]) == 40  # the original car's laser is untouched
    cloud: PointCloud2 = log["/demo/cloud/out"][-1]  # no <output_type>: the plugin's default, PointCloud2
    assert len(log["/demo/cloud/out"]) == 10 and cloud.header.frame_id == "base_link"
    assert [f.name for f in cloud.fields] == ["x", "y", "z", "intensity"] and cloud.point_step == 16
    assert cloud.width == 0  # 10 level beams ahead, nothing within 5 m: every beam left out
    lines = [r.getMessage() for r in caplog.records if "sensor_msgs/Foo" in r.getMessage()]
    assert len(lines) == 1 and "'odd'" in lines[0] and str(path) in lines[0]  # an output type it has not: left out


def test_ros2_camera_and_depth_camera_topics(tmp_path):
    path = tmp_path / "ros2_camera.xacro"
    path.write_text(CAMERA_XACRO)
    try:
        sim = Simulator(world="empty", xacro=path, camera=True, lidar=False, seed=4)
    except RenderingError as exc:
        pytest.skip(str(exc))
    topics = (
        "/demo/front/image_raw", "/demo/front/camera_info", "/demo/depth_cam/image_raw",
        "/demo/depth_cam/depth/image_raw", "/demo/depth_cam/depth/camera_info", "/demo/depth_cam/points",
    )  # fmt: skip
    with sim:
        log = Log(sim, *topics)
        sim.run_until(1.0)
        kinds = {p.block.name: p.kind.name for p in sim.car._planned[1]}
        assert (kinds["front_camera"], kinds["depth_cam"]) == ("camera", "depth_camera")
    for topic in topics:
        assert log[topic], f"nothing on {topic}"
    assert log["/demo/front/image_raw"][-1].header.frame_id == "front_cam"
    assert log["/demo/depth_cam/depth/image_raw"][-1].header.frame_id == "base_link"  # lumped: no <frame_name>
    assert log["/demo/front/camera_info"][-1].width == 64


def test_the_registry_keys_the_ros2_plugins():
    assert plugins.SENSORS[("ray", "libgazebo_ros_ray_sensor.so")] is plugins.RAY_SENSOR
    assert plugins.SENSORS[("depth", "libgazebo_ros_camera.so")] is plugins.DEPTH
    assert plugins.SENSORS[("imu", "libgazebo_ros_imu_sensor.so")] is plugins.IMU


WALL_WORLD = """\
<?xml version="1.0"?>
<sdf version="1.6"><world name="wall">
  <include><uri>model://ground_plane</uri></include>
  <model name="ahead"><static>true</static><pose>3.1 0 1 0 0 0</pose><link name="link">
    <collision name="c"><geometry><box><size>0.2 8 2</size></box></geometry></collision></link></model>
</world></sdf>
"""


def test_a_ros2_point_cloud_puts_the_wall_in_its_plane(tmp_path):
    """PointCloud2 as gazebo_ros's conversion builds it: x, y, z, intensity of every beam that hits, in the sensor
    frame; taken into the world by the link's site, the wall's points lie in its face (x = 3) to 2 cm, and the few
    low beams that meet the ground first in its plane."""
    (tmp_path / "wall.world").write_text(WALL_WORLD)
    rows = RAY.format(n=21, lo=-0.3, hi=0.3, max=8.0).replace(
        "</horizontal></scan>",
        "</horizontal><vertical><samples>5</samples><resolution>1</resolution><min_angle>-0.05</min_angle>"
        "<max_angle>0.1</max_angle></vertical></scan>",
    )
    xacro = USER_XACRO.split("  <xacro:include")[0] + (
        '  <xacro:include filename="$(find racecar_description)/urdf/racecar.xacro"/>\n'
        + _link("cloud_link", "0.1 0 0.1")
        + f"""
  <gazebo reference="cloud_link">
    <sensor type="ray" name="cloud">
      <update_rate>10</update_rate>
      {rows}
      <plugin name="cloud" filename="libgazebo_ros_ray_sensor.so">
        <ros><namespace>/demo</namespace><remapping>~/out:=points</remapping></ros>
        <output_type>sensor_msgs/PointCloud2</output_type><frame_name>cloud_link</frame_name>
      </plugin>
    </sensor>
  </gazebo>
</robot>
"""
    )
    (tmp_path / "cloud.xacro").write_text(xacro)
    with Simulator(
        world=str(tmp_path / "wall.world"), xacro=tmp_path / "cloud.xacro", camera=False, seed=4,
        sensors_off=("laser",), spawn=Spawn(0, 0, 0.05, 0),
    ) as sim:  # fmt: skip
        log = Log(sim, "/demo/points")
        sim.run_until(0.5)
        site = sim.data.site("cloud_link")
        origin, axes = site.xpos.copy(), site.xmat.reshape(3, 3).copy()
    cloud: PointCloud2 = log["/demo/points"][-1]
    assert cloud.header.frame_id == "cloud_link" and cloud.is_dense and cloud.height == 1
    points = np.frombuffer(cloud.data, "<f4").reshape(-1, 4)
    assert cloud.width == len(points) == 21 * 5  # every beam reaches the wall, or the ground just before it
    world = origin + points[:, :3].astype(float) @ axes.T
    ground = np.abs(world[:, 2]) < 1e-3  # on the ground plane itself
    assert ground.sum() < 10
    assert np.abs(world[~ground, 0] - 3.0).max() < 0.02 and not points[:, 3].any()
