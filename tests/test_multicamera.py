"""gazebo_ros_multicamera in a user's xacro: the stereo pair publishes left and right images on <cameraName>/left and
<cameraName>/right, the right CameraInfo carrying the baseline (P's Tx = -fx B), and a pole at depth Z stands
f B / Z pixels apart in the two images (to a pixel): the pinhole model, not the renderer, is the expectation."""

from __future__ import annotations

import math

import numpy as np
import pytest

from conftest import Log
from racecar_sim import Simulator
from racecar_sim.core.errors import RenderingError
from racecar_sim.worlds import Spawn

WIDTH, HEIGHT, HFOV, BASELINE = 320, 240, 1.0, 0.12
FX = WIDTH / (2 * math.tan(HFOV / 2))
POLE_X = 2.5  # the pole's axis, in the world

USER_XACRO = f"""\
<?xml version="1.0"?>
<robot name="racecar" xmlns:xacro="http://www.ros.org/wiki/xacro">
  <xacro:include filename="$(find racecar_description)/urdf/racecar.xacro"/>
  <link name="stereo_link"/>
  <joint name="stereo_joint" type="fixed">
    <parent link="chassis"/><child link="stereo_link"/><origin xyz="0.2 0 0.15" rpy="0 0 0"/>
  </joint>
  <gazebo reference="stereo_link">
    <sensor type="multicamera" name="zed">
      <update_rate>10</update_rate>
      <camera name="left">
        <pose>0 {BASELINE / 2} 0 0 0 0</pose>
        <horizontal_fov>{HFOV}</horizontal_fov>
        <image><width>{WIDTH}</width><height>{HEIGHT}</height><format>R8G8B8</format></image>
        <clip><near>0.02</near><far>50</far></clip>
      </camera>
      <camera name="right">
        <pose>0 {-BASELINE / 2} 0 0 0 0</pose>
        <horizontal_fov>{HFOV}</horizontal_fov>
        <image><width>{WIDTH}</width><height>{HEIGHT}</height><format>R8G8B8</format></image>
        <clip><near>0.02</near><far>50</far></clip>
      </camera>
      <plugin name="stereo_camera_controller" filename="libgazebo_ros_multicamera.so">
        <cameraName>stereo</cameraName><frameName>stereo_link</frameName><hackBaseline>{BASELINE}</hackBaseline>
      </plugin>
    </sensor>
  </gazebo>
</robot>
"""

POLE_WORLD = f"""\
<?xml version="1.0"?>
<sdf version="1.6"><world name="pole">
  <include><uri>model://ground_plane</uri></include>
  <model name="pole"><static>true</static><pose>{POLE_X} 0 1 0 0 0</pose><link name="link">
    <collision name="c"><geometry><box><size>0.02 0.02 2</size></box></geometry></collision>
    <visual name="v"><geometry><box><size>0.02 0.02 2</size></box></geometry>
      <material><ambient>1 0 0 1</ambient><diffuse>1 0 0 1</diffuse></material></visual></link></model>
</world></sdf>
"""


def red_column(msg) -> float:
    """The mean column of the red pixels in the image's middle row."""
    row = msg.bgr_pixels()[msg.height // 2].astype(int)
    red = (row[:, 2] > 120) & (row[:, 1] < 60) & (row[:, 0] < 60)
    assert red.any(), "no red pole in the middle row"
    return float(np.flatnonzero(red).mean())


def test_the_stereo_pairs_disparity_is_f_b_over_z(tmp_path):
    (tmp_path / "zed.xacro").write_text(USER_XACRO)
    (tmp_path / "pole.world").write_text(POLE_WORLD)
    try:
        sim = Simulator(
            world=str(tmp_path / "pole.world"), xacro=tmp_path / "zed.xacro", lidar=False, camera=True,
            sensor_noise=False, seed=1, spawn=Spawn(0, 0, 0.05, 0),
        )  # fmt: skip
    except RenderingError as exc:
        pytest.skip(str(exc))
    topics = (
        "/stereo/left/image_raw",
        "/stereo/right/image_raw",
        "/stereo/left/camera_info",
        "/stereo/right/camera_info",
    )
    with sim:
        log = Log(sim, *topics)
        sim.run_until(1.0)
        camera_x = float(sim.data.site("stereo_link").xpos[0])  # the link frame; the cameras sit on it, side by side
    left, right = log[topics[0]][-1], log[topics[1]][-1]
    assert len(log[topics[0]]) == len(log[topics[1]]) == 10 and left.header.stamp == right.header.stamp
    assert left.header.frame_id == right.header.frame_id == "stereo_link"
    left_info, right_info = log[topics[2]][-1], log[topics[3]][-1]
    assert left_info.p[3] == 0.0 and right_info.p[3] == pytest.approx(-FX * BASELINE, rel=1e-9)
    depth = POLE_X - 0.01 - camera_x  # to the pole's face
    disparity = red_column(left) - red_column(right)
    assert disparity == pytest.approx(FX * BASELINE / depth, abs=1.0)
    # each on its own: the pole is left of the right camera's axis and right of the left camera's, by f (B/2) / Z
    centre = (WIDTH - 1) / 2
    assert red_column(left) - centre == pytest.approx(FX * BASELINE / 2 / depth, abs=1.0)
