"""The Velodyne plugin in a user's xacro: a 16-ring 3-D lidar's PointCloud2 has its 16 rings, and the points it puts
on the wall ahead and on the ground lie in those planes (the world file's wall face, z = 0) to 2 cm, once taken into
the world by the sensor's pose (its link's site, placed by the URDF chain)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from conftest import Log, wall_world
from racecar_sim import Simulator
from racecar_sim.msgs.sensor_msgs import PointCloud2
from racecar_sim.sensors.velodyne import POINT
from racecar_sim.worlds import Spawn

WALL_AHEAD = 3.0
RINGS = 16

USER_XACRO = f"""\
<?xml version="1.0"?>
<robot name="racecar" xmlns:xacro="http://www.ros.org/wiki/xacro">
  <xacro:include filename="$(find racecar_description)/urdf/racecar.xacro"/>
  <link name="velodyne"/>
  <joint name="velodyne_joint" type="fixed">
    <parent link="chassis"/><child link="velodyne"/><origin xyz="0 0 0.25" rpy="0 0 0"/>
  </joint>
  <gazebo reference="velodyne">
    <sensor type="ray" name="VLP16">
      <update_rate>10</update_rate>
      <ray>
        <scan>
          <horizontal><samples>360</samples><resolution>1</resolution>
            <min_angle>-{math.pi}</min_angle><max_angle>{math.pi}</max_angle></horizontal>
          <vertical><samples>{RINGS}</samples><resolution>1</resolution>
            <min_angle>-{math.radians(15)}</min_angle><max_angle>{math.radians(15)}</max_angle></vertical>
        </scan>
        <range><min>0.3</min><max>10.0</max><resolution>0.001</resolution></range>
      </ray>
      <plugin name="gazebo_ros_laser_controller" filename="PLUGIN_FILE">
        <topicName>/velodyne_points</topicName><frameName>velodyne</frameName>
        <min_range>0.9</min_range><max_range>130.0</max_range><gaussianNoise>0.0</gaussianNoise>
      </plugin>
    </sensor>
  </gazebo>
</robot>
"""

WALL_WORLD = wall_world(WALL_AHEAD)


@pytest.mark.parametrize(
    ("sensor_type", "plugin"),
    [("ray", "libgazebo_ros_velodyne_laser.so"), ("gpu_ray", "libgazebo_ros_velodyne_gpu_laser.so")],
)
def test_rings_and_points_in_the_planes_they_hit(tmp_path, sensor_type, plugin):
    xacro = USER_XACRO.replace("PLUGIN_FILE", plugin).replace('<sensor type="ray"', f'<sensor type="{sensor_type}"')
    (tmp_path / "vlp.xacro").write_text(xacro)
    (tmp_path / "wall.world").write_text(WALL_WORLD)
    with Simulator(
        world=str(tmp_path / "wall.world"), xacro=tmp_path / "vlp.xacro", camera=False, seed=1,
        spawn=Spawn(0, 0, 0.05, 0.3),
    ) as sim:  # fmt: skip
        log = Log(sim, "/velodyne_points")
        sim.run_until(1.0)
        site = sim.data.site("velodyne")
        origin, axes = site.xpos.copy(), site.xmat.reshape(3, 3).copy()
    clouds: list[PointCloud2] = log["/velodyne_points"]
    assert len(clouds) == 10
    cloud = clouds[-1]
    assert cloud.header.frame_id == "velodyne" and cloud.height == 1 and cloud.is_dense and cloud.point_step == 32
    assert [(f.name, f.offset, f.datatype) for f in cloud.fields] == [
        ("x", 0, 7), ("y", 4, 7), ("z", 8, 7), ("intensity", 16, 7), ("ring", 20, 4),
    ]  # fmt: skip
    points = np.frombuffer(cloud.data, POINT)
    assert cloud.width == len(points) and cloud.row_step == 32 * len(points)
    assert sorted(set(points["ring"].tolist())) == list(range(RINGS))  # every ring sees something (ground or wall)
    local = np.stack([points["x"], points["y"], points["z"]], axis=1).astype(float)
    world = origin + local @ axes.T
    r = np.linalg.norm(local, axis=1)
    assert r.min() > 0.9  # the plugin's <min_range>
    near_wall, low = world[:, 0] > WALL_AHEAD - 0.1, world[:, 2] < 0.05  # the corner where they meet: either
    on_wall, on_ground = near_wall & ~low, low & ~near_wall
    assert on_wall.sum() > 100 and on_ground.sum() > 100
    assert np.abs(world[on_wall, 0] - WALL_AHEAD).max() < 0.02
    assert np.abs(world[on_ground, 2]).max() < 0.02
    # the lowest ring's points (15 degrees down) reach the ground where geometry says: height / tan(15 deg) away
    lowest = points["ring"] == 0
    reach = np.hypot(local[lowest & on_ground, 0], local[lowest & on_ground, 1])
    assert np.median(reach) == pytest.approx(origin[2] / math.tan(math.radians(15)), rel=0.05)
