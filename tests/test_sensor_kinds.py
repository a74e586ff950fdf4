"""A kind from outside the package: this module registers a sensor kind of its own (a "beam height" reporter keyed as
Gazebo keys it, by <sensor type="ray"> and its own plugin file) with an existing message, and nothing under src/
changes. Its spec is parsed once, its MuJoCo part (its link's site) is bound by the framework after every compile, so
the node never looks an id up, even when a car deleted before it moves every id."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import pytest

from conftest import Log
from racecar_sim import Car, Simulator
from racecar_sim.description.urdf import Sensor
from racecar_sim.msgs.std_msgs import Float64
from racecar_sim.nodes import Mount, NodeBase, NodeContext, Parts
from racecar_sim.runtime import plugins
from racecar_sim.sensors.shared_pose import SharedPose
from racecar_sim.worlds import Spawn

PLUGIN = "libbeam_height.so"
PARSED: list[str] = []  # the blocks parse() read: once each


@dataclass(frozen=True)
class BeamSpec:
    name: str
    link: str
    topic: str
    rate: float


def parse(block: Any, mount: Mount) -> BeamSpec:
    assert isinstance(block, Sensor)
    PARSED.append(f"{mount.names.namespace}:{block.name}")
    params = block.plugins[0].params
    return BeamSpec(block.name, block.link, "/" + params.get("topicName", "beam"), block.update_rate)


def parts(spec: BeamSpec, mount: Mount) -> Parts:
    return Parts.sites(f"beam '{spec.name}'", site=mount.names.mj(spec.link))


class BeamHeight(NodeBase):
    """Publishes its link's height above the ground (m) at every sensor's sampling point."""

    def __init__(self, ctx: NodeContext, spec: BeamSpec) -> None:
        self.ctx, self.parts, self.topic = ctx, ctx.parts, ctx.names.topic(spec.topic)
        self._task = ctx.timers.every(spec.rate, self._tick, f"beam {spec.name}")

    def _tick(self, now_ns: int) -> None:
        pose = SharedPose.of(self.ctx.model, self.ctx.data).update(self.ctx.data)
        self.ctx.bus.publish(self.topic, Float64(float(pose.site_xpos[self.parts["site"]][2])))

    def close(self) -> None:
        self._task.cancel()


BEAM = plugins.NodeKind(BeamHeight, None, "", (PLUGIN,), "beam_height", parse, parts)

USER_XACRO = f"""\
<?xml version="1.0"?>
<robot name="racecar" xmlns:xacro="http://www.ros.org/wiki/xacro">
  <xacro:include filename="$(find racecar_description)/urdf/racecar.xacro"/>
  <link name="beam_link"/>
  <joint name="beam_joint" type="fixed">
    <parent link="chassis"/><child link="beam_link"/><origin xyz="0.1 0 0.2" rpy="0 0 0"/>
  </joint>
  <gazebo reference="beam_link">
    <sensor type="ray" name="beam">
      <update_rate>20</update_rate>
      <ray><scan><horizontal><samples>1</samples></horizontal></scan><range><min>0.1</min><max>5</max></range></ray>
      <plugin name="beam_plugin" filename="{PLUGIN}"><topicName>beam</topicName></plugin>
    </sensor>
  </gazebo>
</robot>
"""


@pytest.fixture
def beam_kind(monkeypatch, tmp_path):
    monkeypatch.setattr(plugins, "SENSORS", dict(plugins.SENSORS))
    plugins.register_sensor("ray", BEAM)
    PARSED.clear()
    path = tmp_path / "beam.xacro"
    path.write_text(USER_XACRO)
    return path


def test_a_kind_registered_from_outside_gets_its_parts_bound_across_a_recompile(beam_kind):
    cars = [
        Car("car1", xacro=beam_kind, spawn=Spawn(0, 0, 0.05, 0), camera=False, lidar=False),
        Car("car2", xacro=beam_kind, spawn=Spawn(0, 3, 0.05, 0), camera=False, lidar=False),
    ]
    with Simulator(world="empty", cars=cars, seed=1) as sim:
        assert sorted(PARSED) == ["car1:beam", "car2:beam"]  # each car's block parsed once, handed to build
        node = next(n for n in cars[1].sensors if isinstance(n, BeamHeight))
        log = Log(sim, "/car2/beam")
        sim.run_until(0.5)
        before = node.parts["site"]
        assert before == sim.model.site("car2/beam_link").id
        assert log["/car2/beam"][-1].data == pytest.approx(sim.data.site("car2/beam_link").xpos[2], abs=1e-6)
        sim.delete_car(cars[0])  # every id of car2 moves down
        after = node.parts["site"]
        assert after == sim.model.site("car2/beam_link").id and after < before
        sim.run_until(1.0)
        height = sim.data.site("car2/beam_link").xpos[2]
    assert log["/car2/beam"][-1].data == pytest.approx(height, abs=1e-6)
    assert 0.2 < height < 0.5  # above the chassis, which rests on its wheels
    assert sorted(PARSED) == ["car1:beam", "car2:beam"]  # not parsed again


def test_an_outside_kind_is_switched_off_by_its_name(beam_kind):
    with Simulator(world="empty", xacro=beam_kind, camera=False, sensors_off=("beam_height",), seed=1) as sim:
        assert not sim.car.has("beam_height") and not any(isinstance(n, BeamHeight) for n in sim.car.sensors)
    assert "beam_height" in plugins.switches()
