"""gazebo_ros_range: a sonar and an IR ranger in a user's xacro publish sensor_msgs/Range on the topic and frame the
plugin's own source gives (gazebo_plugins/src/gazebo_ros_range.cpp), reading the distance to a wall from geometry.

The expectation comes from outside the sensor: the wall's face in the world file and the sensor's site, placed by the
URDF chain in the compiled model. The registry keys the block by (ray, libgazebo_ros_range.so), so it is no laser: the
car's laser is still the Hokuyo, though the rangers come first in the description."""

from __future__ import annotations

import math

import pytest

from conftest import Log, wall_world
from racecar_sim import Simulator
from racecar_sim.msgs.sensor_msgs import Range
from racecar_sim.runtime import plugins
from racecar_sim.worlds import Spawn

WALL_AHEAD = 3.0  # x of the wall's near face
SONAR, IR, SIDE = "/sonar_front", "/racecar/ir/range", "/range"


def _ranger(name: str, link: str, origin: str, scan: str, plugin: str, rate: int = 10) -> str:
    yaw = math.pi / 2 if name == "side" else 0.0
    return f"""
  <link name="{link}"/>
  <joint name="{link}_joint" type="fixed">
    <parent link="chassis"/><child link="{link}"/><origin xyz="{origin}" rpy="0 0 {yaw}"/>
  </joint>
  <gazebo reference="{link}">
    <sensor type="ray" name="{name}">
      <update_rate>{rate}</update_rate>
      <ray><scan>{scan}</scan><range><min>0.02</min><max>2.0</max><resolution>0.01</resolution></range></ray>
      <plugin name="{name}_plugin" filename="libgazebo_ros_range.so">{plugin}</plugin>
    </sensor>
  </gazebo>"""


CONE = (  # 5 x 3 beams, 0.1 rad apart across and 0.03 rad up and down (the ground is out of reach, 3 m ahead)
    "<horizontal><samples>5</samples><resolution>1</resolution><min_angle>-0.2</min_angle><max_angle>0.2</max_angle>"
    "</horizontal><vertical><samples>3</samples><resolution>1</resolution><min_angle>-0.03</min_angle>"
    "<max_angle>0.03</max_angle></vertical>"
)
ROW = (
    "<horizontal><samples>3</samples><resolution>1</resolution><min_angle>-0.02</min_angle>"
    "<max_angle>0.02</max_angle></horizontal>"
)

USER_XACRO = f"""\
<?xml version="1.0"?>
<robot name="racecar" xmlns:xacro="http://www.ros.org/wiki/xacro">
  {_ranger("sonar", "sonar_link", "0.25 0 0.05", CONE,
           "<topicName>sonar_front</topicName><frameName>sonar_link</frameName><radiation>ultrasound</radiation>"
           "<fov>0.2</fov>")}
  {_ranger("ir", "ir_link", "0.25 0.05 0.05", ROW,
           "<robotNamespace>racecar</robotNamespace><topicName>ir/range</topicName><frameName>ir_link</frameName>"
           "<radiation>infrared</radiation><fov>0.04</fov><updateRate>5</updateRate>")}
  {_ranger("side", "side_link", "0 0.1 0.05", CONE, "")}
  <xacro:include filename="$(find racecar_description)/urdf/racecar.xacro"/>
</robot>
"""  # fmt: skip

WALL_WORLD = wall_world(WALL_AHEAD)


@pytest.fixture
def rangers(tmp_path):
    (tmp_path / "wall.world").write_text(WALL_WORLD)
    (tmp_path / "rangers.xacro").write_text(USER_XACRO)
    return tmp_path


def _sim(where, yaw: float = 0.0, **options) -> Simulator:
    return Simulator(
        world=str(where / "wall.world"), xacro=where / "rangers.xacro", camera=False, seed=5,
        spawn=Spawn(2.0 - 0.25, 0, 0.05, yaw), **options,
    )  # fmt: skip


def test_range_to_a_wall_and_max_range_with_nothing_in_the_cone(rangers):
    with _sim(rangers) as sim:
        log = Log(sim, SONAR, IR, SIDE)
        sim.run_until(1.0)
        sonar_x, ir_x = sim.data.site("sonar_link").xpos[0], sim.data.site("ir_link").xpos[0]
        assert sim.car.lidar is not None and sim.car.lidar.topic == "/scan"  # the Hokuyo, not a ranger
        assert plugins.first_sensor(sim.car.robot, "laser").name != "sonar"
    sonar, ir, side = log[SONAR], log[IR], log[SIDE]
    assert len(sonar) == 10 and len(ir) == 5 and len(side) == 10  # <update_rate>, throttled by <updateRate>
    assert all(isinstance(m, Range) for m in sonar + ir + side)
    last = sonar[-1]
    assert last.header.frame_id == "sonar_link" and last.radiation_type == Range.ULTRASOUND
    assert (last.min_range, last.max_range, last.field_of_view) == pytest.approx((0.02, 2.0, 0.2))
    assert last.range == pytest.approx(WALL_AHEAD - sonar_x, abs=0.01)
    assert ir[-1].range == pytest.approx(WALL_AHEAD - ir_x, abs=0.01)
    assert ir[-1].header.frame_id == "ir_link" and ir[-1].radiation_type == Range.INFRARED
    # facing the side, nothing within 2 m: exactly max_range; no <topicName>/<frameName>: the plugin's defaults
    assert [m.range for m in side] == [2.0] * len(side)
    assert side[-1].header.frame_id == "world" and side[-1].field_of_view == pytest.approx(0.05)


def test_the_cone_sees_a_wall_off_its_axis(rangers):
    """Turned 0.5 rad, the sonar's nearest beam is its level one turned back by 0.2: its length to the wall is the
    distance over the cosine of the 0.3 rad left between it and the wall's normal (5 cm more than straight on)."""
    with _sim(rangers, yaw=0.5, sensors_off=("ir", "side")) as sim:
        log = Log(sim, SONAR)
        sim.run_until(0.5)
        sonar = sim.data.site("sonar_link")
        x, axis = sonar.xpos[0], sonar.xmat.reshape(3, 3)[:, 0]
        yaw = math.atan2(axis[1], axis[0])
    assert yaw == pytest.approx(0.5, abs=0.01)
    nearest_turn = min(abs(yaw + h) for h in (-0.2, -0.1, 0.0, 0.1, 0.2))
    expected = (WALL_AHEAD - x) / math.cos(nearest_turn)
    assert log[SONAR][-1].range == pytest.approx(expected, abs=0.01)


def test_an_unknown_pair_is_one_warning_naming_type_plugin_and_file(tmp_path, caplog):
    path = tmp_path / "odd.xacro"
    odd = '<plugin name="side_plugin" filename="libmystery_ray.so">'
    path.write_text(USER_XACRO.replace('<plugin name="side_plugin" filename="libgazebo_ros_range.so">', odd))
    with caplog.at_level("WARNING", logger="racecar_sim"):
        with Simulator(world="empty", xacro=path, camera=False, lidar=False, seed=1) as sim:
            topics = {getattr(n, "topic", None) for n in sim.car.sensors}
    lines = [r.getMessage() for r in caplog.records if "libmystery_ray.so" in r.getMessage()]
    assert len(lines) == 1 and str(path) in lines[0] and "type='ray'" in lines[0] and "name='side'" in lines[0]
    assert SIDE not in topics and SONAR in topics  # the unknown block is left out, the others run


def test_no_sensor_turns_a_kind_or_a_name_off_and_warns_of_a_name_that_turns_nothing_off(rangers, caplog):
    with _sim(rangers, sensors_off=("range",)) as sim:
        assert [type(n).__name__ for n in sim.car.sensors] == ["LidarPublisher"] and not sim.car.has("range")
    with caplog.at_level("WARNING", logger="racecar_sim"):
        with _sim(rangers, sensors_off=("sonar", "sonnar")) as sim:
            assert {n.topic for n in sim.car.sensors} == {"/scan", IR, SIDE}
    lines = [r.getMessage() for r in caplog.records if "sonnar" in r.getMessage()]
    assert len(lines) == 1 and "turns nothing off" in lines[0] and "range" in lines[0]
    assert {"laser", "range", "camera", "depth_camera", "imu", "lidar"} <= set(plugins.switches())
