"""gazebo_ros_bumper: gazebo_msgs/ContactsState of a `<sensor type="contact">` block, from MuJoCo's contacts.

As gazebo_plugins/src/gazebo_ros_bumper.cpp (ROS 1) fills it: on every update of the contact sensor (its
<update_rate>; 0: every physics step), while someone listens, one ContactState per contact of the sensor's collision
with anything else, stamped at the update's sim time, in the world frame (the plugin reports world values whatever
<frameName> says; the header carries <frameName>, default world). Topic <bumperTopicName> (default bumper_states)
under ros::NodeHandle(<robotNamespace>).

Per contact: collision1_name is the sensor's collision and collision2_name what it touches, both as Gazebo scopes
them (model::link::collision: a wall of the world file `ahead::link::c`, another car's chassis
`car2::chassis::chassis_collision`); one contact point each (MuJoCo's), with its position, the normal pointing into
collision1 (the way the other body pushes it), the depth of interpenetration and the wrench on collision1 (world
frame, about the contact point). The sensor's collision is every collision of its link (the URDF link's own geoms):
Gazebo names a lumped link's collisions after the link it was lumped into, which the description's <collision> tag
then spells; any of them counts.

Sampling point: every sensor's, the end of the last physics step (the contacts of the state there: shared_pose.py).
"""

from __future__ import annotations

import re
from dataclasses import dataclass

import mujoco
import numpy as np

from racecar_sim.core.errors import DescriptionError
from racecar_sim.description.urdf import Robot, Sensor
from racecar_sim.msgs.gazebo_msgs import ContactsState, ContactState
from racecar_sim.msgs.geometry_msgs import Vector3, Wrench
from racecar_sim.msgs.std_msgs import Header
from racecar_sim.nodes import Mount, NodeBase, NodeContext, Parts
from racecar_sim.sensors.sensor_xml import join_topic, sensor_number
from racecar_sim.sensors.shared_pose import SharedPose

PLUGIN = "libgazebo_ros_bumper.so"
_GEOM = mujoco.mjtObj.mjOBJ_GEOM
_OWN_COLLISION = re.compile(r"^(?P<link>.+)_collision\d*(#\d+)?$")


@dataclass(frozen=True)
class BumperSpec:
    """A contact sensor with gazebo_ros_bumper: its link, the collision it names, its rate, topic and frame."""

    name: str
    link: str
    collision: str
    update_rate: float
    topic: str
    frame_id: str
    collisions: int  # how many collision geoms the link has

    @classmethod
    def from_sensor(cls, sensor: Sensor, robot: Robot) -> BumperSpec:
        """Read a `<sensor type="contact">` block holding gazebo_ros_bumper (DescriptionError naming what is wrong)."""
        where = f"<sensor type='contact' name='{sensor.name}'> on link {sensor.link}"
        plugin = next((p for p in sensor.plugins if p.filename == PLUGIN), None)
        if plugin is None:
            raise DescriptionError(f"{where}: no <plugin filename='{PLUGIN}'> inside")
        link = robot.links.get(sensor.link)
        if link is None or not link.collisions:
            raise DescriptionError(f"{where}: link {sensor.link} has no <collision> for the sensor to feel")
        collision = (sensor.element.findtext("contact/collision") or "").strip()
        if not collision:
            raise DescriptionError(f"{where}: <contact><collision> is missing (the collision the sensor reports)")
        rate = sensor_number(sensor.element, "update_rate", where, default=0.0)
        if rate < 0:
            raise DescriptionError(f"{where}: <update_rate> must not be negative, got {rate:g}")
        params = plugin.params
        return cls(
            sensor.name,
            sensor.link,
            collision,
            rate,
            join_topic(params.get("robotNamespace", ""), params.get("bumperTopicName") or "bumper_states"),
            (params.get("frameName") or "world").lstrip("/"),
            len(link.collisions),
        )


def bumper_parts(spec: BumperSpec, mount: Mount) -> Parts:
    """The bumper's parts: the collision geoms of its link, as the model builder names them."""
    names = mount.names
    geoms = {
        f"geom{i}": (_GEOM, names.mj(f"{spec.link}_collision{'' if i == 0 else i}")) for i in range(spec.collisions)
    }
    return Parts(f"bumper '{spec.name}'", **geoms)


def gazebo_name(model: mujoco.MjModel, geom: int, model_of: dict[str, str]) -> str:
    """A geom's collision name as Gazebo scopes it: model::link::collision (see the module doc)."""
    name = mujoco.mj_id2name(model, _GEOM, geom) or ""
    if "::" in name:  # a world body's geom: model::link/collision
        head, _, collision = name.rpartition("/")
        return f"{head}::{collision}" if head else name
    namespace, _, local = name.rpartition("/")
    own = _OWN_COLLISION.match(local)
    if own is not None:  # a car's: its namespace (or racecar), its URDF link, the link's collision
        return f"{model_of.get(namespace, namespace or 'racecar')}::{own['link']}::{local.split('#')[0]}"
    body = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, int(model.geom_bodyid[geom])) or "world"
    return f"{body}::{name or f'geom{geom}'}"


class BumperPublisher(NodeBase):
    """gazebo_ros_bumper: ContactsState on its topic at the contact sensor's rate, while someone listens."""

    def __init__(self, ctx: NodeContext, spec: BumperSpec) -> None:
        self.ctx, self.spec = ctx, spec
        self.topic = ctx.names.topic(spec.topic)
        self.frame_id = spec.frame_id if spec.frame_id in ("world", "map") else ctx.names.frame(spec.frame_id)
        self.parts = ctx.parts
        self._models = {ctx.names.namespace: ctx.names.model}
        self._wrench = np.zeros(6)
        rate = spec.update_rate if spec.update_rate > 0 else 1e9 / ctx.timers.step_ns
        self._task = ctx.timers.every(rate, self._tick, f"bumper {spec.name}")

    def _tick(self, now_ns: int) -> None:
        if self.ctx.bus.has_listeners(self.topic):
            self.ctx.bus.publish(self.topic, self.measure(now_ns))

    def measure(self, stamp_ns: int) -> ContactsState:
        """The contacts of the sensor's collision now, stamped `stamp_ns`."""
        model = self.ctx.model
        data = SharedPose.of(model, self.ctx.data).forward(self.ctx.data)
        own = {self.parts[f"geom{i}"] for i in range(self.spec.collisions)}
        touching = []
        for index in range(data.ncon):
            g1, g2 = (int(g) for g in data.contact.geom[index])
            if (g1 in own) == (g2 in own):  # not ours, or ours against ours
                continue
            touching.append((index, g1, g2))
        sec, nsec = divmod(stamp_ns, 1_000_000_000)
        states = []
        for i, (index, g1, g2) in enumerate(touching):
            contact = data.contact[index]
            mine, other = (g1, g2) if g1 in own else (g2, g1)
            frame = contact.frame.reshape(3, 3)  # rows: the normal (from geom1 to geom2), then the tangents
            mujoco.mj_contactForce(model, data, index, self._wrench)
            # the force geom1 puts on geom2, in the world: on our collision with the sign of our side
            sign = 1.0 if mine == g2 else -1.0
            force, torque = sign * (frame.T @ self._wrench[:3]), sign * (frame.T @ self._wrench[3:])
            normal = frame[0] if mine == g2 else -frame[0]  # into collision1: the way the other body pushes it
            first, second = gazebo_name(model, mine, self._models), gazebo_name(model, other, self._models)
            wrench = Wrench(Vector3(*force.tolist()), Vector3(*torque.tolist()))
            states.append(
                ContactState(
                    f"Debug:  i:({i}/{len(touching)})     my geom:{first}   other geom:{second}         "
                    f"time:{sec}.{nsec:09d}\n",
                    first,
                    second,
                    [wrench],
                    Wrench(Vector3(*force.tolist()), Vector3(*torque.tolist())),
                    [Vector3(*contact.pos.tolist())],
                    [Vector3(*normal.tolist())],
                    np.array([-float(contact.dist)]),
                )
            )
        return ContactsState(Header.at(stamp_ns, self.frame_id), states)

    def close(self) -> None:
        """Stop publishing."""
        self._task.cancel()
