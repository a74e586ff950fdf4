"""gazebo_ros_p3d: ground-truth odometry of one link, from a `<plugin filename="libgazebo_ros_p3d.so">` block.

nav_msgs/Odometry on /<robotNamespace>/<topicName> at <updateRate> Hz (0: every physics step), frame <frameName>
(`world` by default; the world frames world and map are taken, as the original sim's map is Gazebo's world), child
<bodyName>: the link's pose and twist (world frame, the linear velocity of the link's origin), with <gaussianNoise>
added to the pose and twist and its square on the covariance diagonals, and <xyzOffsets>/<rpyOffsets> applied to
the pose as the plugin does, read at every sensor's sampling point (the end of the last physics step,
sensors/shared_pose.py). Published only while someone listens.
"""

from __future__ import annotations

import math

import mujoco
import numpy as np

from racecar_sim.core.errors import DescriptionError
from racecar_sim.core.names import WORLD_FRAME
from racecar_sim.core.rng import NoiseTable
from racecar_sim.core.transforms import quat_from_rpy, quat_mul
from racecar_sim.description.urdf import Plugin
from racecar_sim.msgs import (
    Header,
    Odometry,
    Point,
    Pose,
    PoseWithCovariance,
    Quaternion,
    Twist,
    TwistWithCovariance,
    Vector3,
)
from racecar_sim.nodes import NodeBase, NodeContext, Parts
from racecar_sim.sensors.sensor_xml import plugin_number
from racecar_sim.sensors.shared_pose import SharedPose

P3D_PLUGIN = "libgazebo_ros_p3d.so"
WORLD_FRAMES = ("world", "/world", WORLD_FRAME, "/" + WORLD_FRAME)
_SITE = int(mujoco.mjtObj.mjOBJ_SITE)


def _three(params: dict[str, str], tag: str, where: str) -> np.ndarray:
    text = params.get(tag, "0 0 0")
    try:
        values = [float(v) for v in text.split()]
    except ValueError:
        values = []
    if len(values) != 3 or not all(math.isfinite(v) for v in values):
        raise DescriptionError(f"{where}: <{tag}> '{text}' is not 3 numbers")
    return np.array(values)


class GroundTruthOdometry(NodeBase):
    """The p3d plugin's node."""

    def __init__(self, ctx: NodeContext, plugin: Plugin) -> None:
        robot = ctx.need_robot("gazebo_ros_p3d")
        params, names = plugin.params, ctx.names
        where = f"<plugin name='{plugin.name}' filename='{P3D_PLUGIN}'> in {robot.source or robot.name}"
        body = params.get("bodyName", "")
        if body not in robot.links:
            raise DescriptionError(f"{where}: <bodyName> '{body}' is not a link of {robot.name}")
        topic = params.get("topicName", "")
        if not topic:
            raise DescriptionError(f"{where}: <topicName> is missing")
        frame = params.get("frameName", "world")
        if frame not in WORLD_FRAMES:
            raise DescriptionError(f"{where}: <frameName> '{frame}': only the world frame (world, map) is supported")
        self.ctx = ctx
        namespace = params.get("robotNamespace", "").strip("/")
        self.topic = names.topic(topic if topic.startswith("/") else "/" + "/".join(p for p in (namespace, topic) if p))
        self.frame_id, self.child_frame_id = frame.lstrip("/"), names.frame(body)
        self.noise_stddev = plugin_number(params, "gaussianNoise", where, 0.0)
        if self.noise_stddev < 0:
            raise DescriptionError(f"{where}: <gaussianNoise> must not be negative")
        self._xyz_offset = _three(params, "xyzOffsets", where)
        self._rpy_offset = quat_from_rpy(_three(params, "rpyOffsets", where))
        variance = self.noise_stddev**2
        self._covariance = np.diag([variance] * 6).reshape(-1)
        self._covariance.flags.writeable = False
        self.seed = ctx.seed
        self.noise = ctx.noise and self.noise_stddev > 0
        self.noise_table = NoiseTable.shared(ctx.noise_stream(f"p3d/{body}"), 12)
        # the link's site, bound by the car (or here, for a p3d built on its own)
        own = Parts.sites(where, site=names.mj(body))
        self.parts = ctx.parts if ctx.parts.declares("site") else own.bind(ctx.model)
        self._owns_parts = self.parts is not ctx.parts
        self._vel = np.zeros(6)
        rate = plugin_number(params, "updateRate", where, 0.0)
        if rate < 0:
            raise DescriptionError(f"{where}: <updateRate> must not be negative, got {rate:g}")
        self._task = ctx.timers.every(rate or 1e9 / ctx.timers.step_ns, self._tick, f"p3d {body}")

    def _tick(self, now_ns: int) -> None:
        if self.ctx.bus.has_listeners(self.topic):
            self.ctx.bus.publish(self.topic, self.measure(now_ns))

    def measure(self, stamp_ns: int) -> Odometry:
        """The link's odometry now, stamped `stamp_ns`."""
        model = self.ctx.model
        data = SharedPose.of(model, self.ctx.data).forward(self.ctx.data)  # every sensor's sampling point
        site = self.parts["site"]
        quat = np.empty(4)
        mujoco.mju_mat2Quat(quat, data.site_xmat[site])
        position = data.site_xpos[site] + self._xyz_offset
        quat = quat_mul(self._rpy_offset, quat)
        mujoco.mj_objectVelocity(model, data, _SITE, site, self._vel, 0)
        angular, linear = self._vel[:3], self._vel[3:]
        values = np.concatenate([position, quat[1:], [quat[0]], linear, angular])
        if self.noise:
            noise = self.noise_stddev * self.noise_table.sample(self.seed, stamp_ns)
            values[:3] += noise[:3]
            values[7:] += noise[6:]
        x, y, z, qx, qy, qz, qw, vx, vy, vz, wx, wy, wz = (float(v) for v in values)
        cov = self._covariance
        return Odometry(
            Header.at(stamp_ns, self.frame_id),
            self.child_frame_id,
            PoseWithCovariance(Pose(Point(x, y, z), Quaternion(qx, qy, qz, qw)), cov),
            TwistWithCovariance(Twist(Vector3(vx, vy, vz), Vector3(wx, wy, wz)), cov),
        )

    def reset(self, seed: int) -> None:
        self.seed = seed

    def rebind(self, model: mujoco.MjModel, data: mujoco.MjData) -> None:
        if self._owns_parts:
            self.parts.bind(model)

    def close(self) -> None:
        self._task.cancel()
