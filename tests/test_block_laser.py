"""gazebo_ros_block_laser in a user's xacro: a PointCloud with a point per beam, the points on the wall ahead in its
plane to 2 cm (the plugin's half-step angles included), the plugin's downward z, and a beam that hits nothing at
range_max - range_min."""

from __future__ import annotations

import numpy as np
import pytest

from conftest import Log, wall_world
from racecar_sim import Simulator
from racecar_sim.msgs.sensor_msgs import PointCloud
from racecar_sim.worlds import Spawn

WALL_AHEAD = 3.0
ROWS, COLUMNS = 9, 81


def _block(name: str, link: str, yaw: float, rows: int, columns: int, range_max: float, topic: str) -> str:
    return f"""
  <link name="{link}"/>
  <joint name="{link}_joint" type="fixed">
    <parent link="chassis"/><child link="{link}"/><origin xyz="0.1 0 0.2" rpy="0 0 {yaw}"/>
  </joint>
  <gazebo reference="{link}">
    <sensor type="ray" name="{name}">
      <update_rate>5</update_rate>
      <ray>
        <scan>
          <horizontal><samples>{columns}</samples><resolution>1</resolution>
            <min_angle>-0.4</min_angle><max_angle>0.4</max_angle></horizontal>
          <vertical><samples>{rows}</samples><resolution>1</resolution>
            <min_angle>-0.1</min_angle><max_angle>0.1</max_angle></vertical>
        </scan>
        <range><min>0.2</min><max>{range_max}</max><resolution>0.01</resolution></range>
      </ray>
      <plugin name="{name}_plugin" filename="libgazebo_ros_block_laser.so">
        <topicName>{topic}</topicName><frameName>{link}</frameName><gaussianNoise>0.0</gaussianNoise>
      </plugin>
    </sensor>
  </gazebo>"""


USER_XACRO = f"""\
<?xml version="1.0"?>
<robot name="racecar" xmlns:xacro="http://www.ros.org/wiki/xacro">
  <xacro:include filename="$(find racecar_description)/urdf/racecar.xacro"/>
  {_block("block", "block_link", 0.0, ROWS, COLUMNS, 10.0, "/block_cloud")}
  {_block("side_block", "side_block_link", 1.5707963267948966, 3, 5, 2.0, "/side_cloud")}
</robot>
"""

WALL_WORLD = wall_world(WALL_AHEAD)


def test_a_point_per_beam_on_the_wall_plane(tmp_path):
    (tmp_path / "block.xacro").write_text(USER_XACRO)
    (tmp_path / "wall.world").write_text(WALL_WORLD)
    with Simulator(
        world=str(tmp_path / "wall.world"), xacro=tmp_path / "block.xacro", camera=False, seed=1,
        sensors_off=("laser",), spawn=Spawn(0, 0, 0.05, 0),
    ) as sim:  # fmt: skip
        log = Log(sim, "/block_cloud", "/side_cloud")
        sim.run_until(1.0)
        site = sim.data.site("block_link")
        origin, axes = site.xpos.copy(), site.xmat.reshape(3, 3).copy()
    clouds: list[PointCloud] = log["/block_cloud"]
    assert len(clouds) == 5
    cloud = clouds[-1]
    assert cloud.header.frame_id == "block_link" and len(cloud.points) == ROWS * COLUMNS
    (channel,) = cloud.channels
    assert channel.name == "" and len(channel.values) == ROWS * COLUMNS and not channel.values.any()
    local = np.array([(p.x, p.y, p.z) for p in cloud.points], dtype=float)
    flipped = local * np.array([1.0, 1.0, -1.0])  # the plugin's z points down: undo it to place the points
    world = origin + flipped @ axes.T
    ground = world[:, 2] < 0.05  # the lowest beams reach the ground first, short of the wall
    assert 0 < ground.sum() < len(world) // 2
    assert np.abs(world[~ground, 0] - WALL_AHEAD).max() < 0.02
    # the ground's points are placed half a row up (the plugin's angles), but their ranges are the beams': a beam 0.1
    # rad down reaches the plane z = 0 where r sin(0.1) is the sensor's height, whatever its turn
    r = np.linalg.norm(local[ground], axis=1)
    assert r * np.sin(0.1) == pytest.approx(np.full(len(r), origin[2]), abs=0.02)
    top_row = local[-COLUMNS:]  # the highest beams (+0.1 rad) hit the wall above the sensor, published below it
    assert (top_row[:, 2] < 0).all()
    side = log["/side_cloud"][-1]  # facing the side, nothing within 2 m: every point at range_max - range_min
    ranges = np.linalg.norm([(p.x, p.y, p.z) for p in side.points], axis=1)
    assert len(ranges) == 15 and ranges == pytest.approx(np.full(15, 2.0 - 0.2), abs=1e-6)
