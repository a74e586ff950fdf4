"""The Velodyne plugin (libgazebo_ros_velodyne_laser.so, velodyne_simulator): a multi-ring 3-D lidar's
sensor_msgs/PointCloud2 with the fields x, y, z, intensity, ring.

As velodyne_gazebo_plugins/src/GazeboRosVelodyneLaser.cpp (ROS 1) builds it from a `<sensor type="ray">` (or
"gpu_ray") block: beam (i, j) of <horizontal> sample i and <vertical> sample j (ring j, counted from the lowest)
points along (cos p cos y, cos p sin y, sin p) in the sensor frame; its range r (no hit: the span range_max -
range_min) plus N(0, <gaussianNoise>) gives the point r (cos p cos y, cos p sin y, sin p) when
max(<min_range>, range_min) < r < min(<max_range>, range_max - range_min - 0.01). A point is 32 bytes: x, y, z
(float32 at 0, 4, 8), intensity (float32 at 16: 0 here, no surface declares a retro-reflectance) and ring (uint16 at
20); the cloud is one row of the points kept, dense, rings in order. Topic <topicName> (default /points) under
<robotNamespace>, frame <frameName> (default world), published at the sensor's rate while someone listens.

The beams are cast by the lidar's 3-D caster (sensors/raycast/mujoco3d.py: the world's geoms, a map's walls, other
cars; never the car itself) at every sensor's sampling point, the end of the last physics step (shared_pose.py).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import mujoco
import numpy as np

from racecar_sim.core.errors import DescriptionError
from racecar_sim.core.rng import NoiseTable
from racecar_sim.core.transforms import quat_from_rpy, quat_to_matrix
from racecar_sim.description.urdf import Origin, Sensor
from racecar_sim.msgs.sensor_msgs import PointCloud, PointCloud2, PointField
from racecar_sim.msgs.std_msgs import Header
from racecar_sim.nodes import NodeBase, NodeContext
from racecar_sim.physics import COLLISION_GROUP
from racecar_sim.physics.near_walls import WallBoxes
from racecar_sim.sensors.ray_block import OnRay, RayBlock
from racecar_sim.sensors.raycast.mujoco3d import MujocoRays
from racecar_sim.sensors.raycast.scene import seen_geoms, subtree_bodies
from racecar_sim.sensors.sensor_xml import plugin_number, topic_and_frame
from racecar_sim.sensors.shared_pose import SharedPose

PLUGIN = "libgazebo_ros_velodyne_laser.so"
GPU_PLUGIN = "libgazebo_ros_velodyne_gpu_laser.so"
POINT_STEP = 32
FIELDS = (
    PointField("x", 0, PointField.FLOAT32, 1),
    PointField("y", 4, PointField.FLOAT32, 1),
    PointField("z", 8, PointField.FLOAT32, 1),
    PointField("intensity", 16, PointField.FLOAT32, 1),
    PointField("ring", 20, PointField.UINT16, 1),
)
POINT = np.dtype({"names": ["x", "y", "z", "intensity", "ring"], "formats": ["<f4", "<f4", "<f4", "<f4", "<u2"],
                  "offsets": [0, 4, 8, 16, 20], "itemsize": POINT_STEP})  # fmt: skip


@dataclass(frozen=True)
class VelodyneSpec(OnRay):
    """A Velodyne block: its ray block's beams, the plugin's cut-offs and noise, topic and frame."""

    ray: RayBlock
    min_range: float  # the plugin's <min_range>
    max_range: float  # the plugin's <max_range>
    gaussian_noise: float
    topic: str
    frame_id: str

    @classmethod
    def from_sensor(cls, sensor: Sensor) -> VelodyneSpec:
        """Read a ray block holding the Velodyne plugin (DescriptionError naming what is wrong)."""
        plugin = next((p.filename for p in sensor.plugins if p.filename in (PLUGIN, GPU_PLUGIN)), PLUGIN)
        ray, params, where = RayBlock.read(sensor, plugin, rated=True)
        low, high = plugin_number(params, "min_range", where, 0.0), plugin_number(params, "max_range", where, math.inf)
        return cls(ray, low, high, noise_stddev(params, where), *topic_and_frame(params, "/points"))


def noise_stddev(params: dict[str, str], where: str) -> float:
    """A plugin's <gaussianNoise> (default 0; DescriptionError if negative)."""
    noise = plugin_number(params, "gaussianNoise", where, 0.0)
    if noise < 0:
        raise DescriptionError(f"{where}: <gaussianNoise> must not be negative, got {noise:g}")
    return noise


class BeamCaster:
    """A 3-D lidar's beams cast from its link: the link's site (bound for the node), the sensor's pose on it, and the
    3-D caster of the world the car is in (rebuilt after a recompile). Shared by the Velodyne and the block laser."""

    def __init__(self, ctx: NodeContext, pose: Origin, what: str) -> None:
        self.ctx, self.parts = ctx, ctx.parts
        self._root = ctx.names.mj(ctx.need_robot(what).root)
        self._offset = np.array(pose.xyz, dtype=float)
        self._turn = quat_to_matrix(quat_from_rpy(pose.rpy))
        self.rebind(ctx.model, ctx.data)

    def rebind(self, model: mujoco.MjModel, data: mujoco.MjData) -> None:
        """Cast in a recompiled model."""
        self.model, self.data = model, data
        self._shared = SharedPose.of(model, data)
        geoms = seen_geoms(model, COLLISION_GROUP)
        own = geoms[np.isin(model.geom_bodyid[geoms], subtree_bodies(model, model.body(self._root).id))]
        self.rays = MujocoRays(model, self._shared.pose, COLLISION_GROUP, own, WallBoxes.of(model))

    def ray_origin(self) -> tuple[np.ndarray, np.ndarray]:
        """World position of the ray origin and the sensor's axes (world from sensor) at the sampling point."""
        pose = self._shared.update(self.data)
        site = self.parts["site"]
        rotation = pose.site_xmat[site].reshape(3, 3)
        return pose.site_xpos[site] + rotation @ self._offset, rotation @ self._turn

    def cast(self, local: np.ndarray, range_min: float, range_max: float) -> np.ndarray:
        """Distances (m) along the beams `local` (unit directions in the sensor frame, (n, 3)) to their first hit
        between range_min and range_max, inf if none."""
        origin, axes = self.ray_origin()
        return self.rays.cast_rays(origin, local @ axes.T, range_min, range_max)


class CloudPublisher(NodeBase):
    """A 3-D lidar's node (Velodyne, block laser, ROS 2's ray sensor cloud): its topic and frame by the plugin's rule,
    its beams cast by a BeamCaster, and `cloud(stamp_ns)` published at `rate` while someone listens. Subclasses build
    the cloud; `seed` is the noise's seed from the last reset."""

    def __init__(self, ctx: NodeContext, spec: OnRay, topic: str, frame_id: str, rate: float, label: str) -> None:
        self.ctx, self.seed = ctx, ctx.seed
        self.topic = ctx.names.topic(topic)
        self.frame_id = frame_id if frame_id in ("world", "map") else ctx.names.frame(frame_id)
        self.beams = BeamCaster(ctx, spec.pose, f"a {label}")
        self._task = ctx.timers.every(rate, self._tick, f"{label.lower()} {spec.name}")

    def cloud(self, stamp_ns: int) -> PointCloud2 | PointCloud:
        """The cloud of a scan taken now, stamped `stamp_ns`."""
        raise NotImplementedError

    def rebind(self, model: mujoco.MjModel, data: mujoco.MjData) -> None:
        """Cast in a recompiled model (its site's id is bound for the node)."""
        self.beams.rebind(model, data)

    def _tick(self, now_ns: int) -> None:
        if self.ctx.bus.has_listeners(self.topic):
            self.ctx.bus.publish(self.topic, self.cloud(now_ns))

    def reset(self, seed: int) -> None:
        """Noise from `seed` from now on."""
        self.seed = seed

    def close(self) -> None:
        """Stop publishing."""
        self._task.cancel()


class VelodynePublisher(CloudPublisher):
    """The Velodyne plugin's node: PointCloud2 on its topic at the sensor's rate (see the module doc)."""

    def __init__(self, ctx: NodeContext, spec: VelodyneSpec) -> None:
        self.spec = spec
        ray = spec.ray
        super().__init__(ctx, spec, spec.topic, spec.frame_id, ray.update_rate, "Velodyne")
        self._local = ray.directions()
        self._rings = np.repeat(np.arange(ray.vertical.samples, dtype=np.uint16), ray.horizontal.samples)
        self.noise = ctx.noise and spec.gaussian_noise > 0
        self.noise_table = NoiseTable.shared(ctx.noise_stream(f"velodyne/{spec.name}"), len(self._local))
        self._lo = max(spec.min_range, ray.range_min)
        self._hi = min(spec.max_range, ray.range_max - ray.range_min - 0.01)

    def ranges(self, stamp_ns: int) -> np.ndarray:
        """Every beam's range (m) now, ring by ring, as the plugin reads it (no hit: the span; with noise)."""
        spec, ray = self.spec, self.spec.ray
        r = self.beams.cast(self._local, ray.range_min, ray.range_max)
        np.minimum(r, ray.range_max - ray.range_min, out=r)
        if self.noise:
            r += spec.gaussian_noise * self.noise_table.sample(self.seed, stamp_ns)
        return r

    def cloud(self, stamp_ns: int) -> PointCloud2:
        """The cloud of a scan taken now, stamped `stamp_ns`."""
        r = self.ranges(stamp_ns)
        kept = (self._lo < r) & (r < self._hi)
        points = np.zeros(int(kept.sum()), POINT)
        xyz = self._local[kept] * r[kept, None]
        points["x"], points["y"], points["z"] = xyz[:, 0], xyz[:, 1], xyz[:, 2]
        points["ring"] = self._rings[kept]
        n = len(points)
        header = Header.at(stamp_ns, self.frame_id)
        return PointCloud2(header, 1, n, list(FIELDS), False, POINT_STEP, n * POINT_STEP, points.tobytes(), True)
