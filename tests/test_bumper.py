"""gazebo_ros_bumper in a user's xacro: a bumper on the car's nose reports the wall the car drives into, named as
Gazebo scopes it, from the update at which the bumper's face reaches the wall (geometry: the wall's face in the world
file, the bumper's box placed by the URDF chain), with the normal and the force pushing the car back."""

from __future__ import annotations

import pytest

from conftest import wall_world
from racecar_sim import Simulator
from racecar_sim.drivers import ConstantCommand
from racecar_sim.msgs.gazebo_msgs import ContactsState
from racecar_sim.worlds import Spawn

WALL_AHEAD = 3.0  # x of the wall's near face
HALF_DEPTH = 0.025  # the bumper box's half length along the car
TOPIC = "/racecar/bumper"

USER_XACRO = f"""\
<?xml version="1.0"?>
<robot name="racecar" xmlns:xacro="http://www.ros.org/wiki/xacro">
  <xacro:include filename="$(find racecar_description)/urdf/racecar.xacro"/>
  <link name="bumper_link">
    <collision><geometry><box size="{2 * HALF_DEPTH} 0.3 0.05"/></geometry></collision>
    <inertial><mass value="0.01"/><inertia ixx="1e-5" ixy="0" ixz="0" iyy="1e-5" iyz="0" izz="1e-5"/></inertial>
  </link>
  <joint name="bumper_joint" type="fixed">
    <parent link="chassis"/><child link="bumper_link"/><origin xyz="0.45 0 0.05" rpy="0 0 0"/>
  </joint>
  <gazebo reference="bumper_link">
    <sensor type="contact" name="bumper">
      <update_rate>50</update_rate>
      <contact><collision>base_link_fixed_joint_lump__bumper_link_collision</collision></contact>
      <plugin name="bumper_plugin" filename="libgazebo_ros_bumper.so">
        <robotNamespace>racecar</robotNamespace><bumperTopicName>bumper</bumperTopicName>
        <frameName>world</frameName>
      </plugin>
    </sensor>
  </gazebo>
</robot>
"""

WALL_WORLD = wall_world(WALL_AHEAD)


def test_the_bumper_reports_the_wall_the_car_hits_when_it_hits_it(tmp_path):
    (tmp_path / "bumper.xacro").write_text(USER_XACRO)
    (tmp_path / "wall.world").write_text(WALL_WORLD)
    face: dict[int, float] = {}  # the bumper's front face (x) at each update the bumper published
    with Simulator(
        world=str(tmp_path / "wall.world"), xacro=tmp_path / "bumper.xacro", camera=False, lidar=False, seed=2,
        spawn=Spawn(0, 0, 0.05, 0),
    ) as sim:  # fmt: skip
        states: list[ContactsState] = []

        def on_bump(msg: ContactsState) -> None:
            face[msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec] = float(
                sim.data.site("bumper_link").xpos[0] + HALF_DEPTH
            )
            states.append(msg)

        sim.subscribe(TOPIC, on_bump)
        ConstantCommand(sim.bus, sim.scheduler, 1.0, 0.0)
        sim.run_until(6.0)
        crash = next(c for c in sim.collisions.crashes if c.what.startswith("ahead"))
    assert len(states) == pytest.approx(50 * 6, abs=1)  # every update of the 50 Hz contact sensor, hit or not
    assert {m.header.frame_id for m in states} == {"world"}
    hits = [m for m in states if any(s.collision2_name == "ahead::link::c" for s in m.states)]
    assert hits, "the bumper never reported the wall"
    first = hits[0]
    stamp = first.header.stamp.sec * 10**9 + first.header.stamp.nanosec
    before = states[states.index(first) - 1]
    before_stamp = before.header.stamp.sec * 10**9 + before.header.stamp.nanosec
    assert not before.states and face[before_stamp] < WALL_AHEAD  # one update earlier: clear of the wall
    assert face[stamp] == pytest.approx(WALL_AHEAD, abs=0.03)  # at the wall (it moves 2 cm an update)
    assert abs(crash.time_ns - stamp) <= 20_000_000  # the crash watch saw it within the same update
    state = next(s for s in first.states if s.collision2_name == "ahead::link::c")
    assert state.collision1_name == "racecar::bumper_link::bumper_link_collision"
    assert "my geom:racecar::bumper_link::bumper_link_collision" in state.info
    (position,), (normal,) = state.contact_positions, state.contact_normals
    assert position.x == pytest.approx(WALL_AHEAD, abs=0.03) and abs(position.y) <= 0.15 + 1e-6
    assert normal.x == pytest.approx(-1.0, abs=1e-3)  # the wall pushes the bumper back
    assert state.total_wrench.force.x < 0 and state.wrenches[0].force.x == state.total_wrench.force.x
    assert state.depths[0] >= 0
