"""gazebo_ros_block_laser (libgazebo_ros_block_laser.so): a `<sensor type="ray">` block's beams as a
sensor_msgs/PointCloud, as gazebo_plugins/src/gazebo_ros_block_laser.cpp (ROS 1) fills it.

Every beam gives a point, hit or not: its range r (a beam that hits nothing: its full length, range_max; every range
capped at range_max - range_min) along the direction the plugin computes for it. That direction is the plugin's own:
the angles halfway to the next beam (the last beam of a row or column keeps its own), and z pointing down
(x = r cos p cos y, y = r cos p sin y, z = -r sin p). N(0, <gaussianNoise>) is added to x, y and z of a point below
the cap, and to its channel's value; the one channel (unnamed, as the plugin leaves it) holds the beams' intensity
(0 here: no surface declares a retro-reflectance). Topic <topicName> (default /world) under <robotNamespace>, frame
<frameName> (default world), published at the sensor's rate while someone listens.

The beams are cast by the 3-D caster (velodyne.BeamCaster) at every sensor's sampling point, the end of the last step.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from racecar_sim.core.rng import NoiseTable
from racecar_sim.description.urdf import Sensor
from racecar_sim.msgs.geometry_msgs import Point32
from racecar_sim.msgs.sensor_msgs import ChannelFloat32, PointCloud
from racecar_sim.msgs.std_msgs import Header
from racecar_sim.nodes import NodeContext
from racecar_sim.sensors.ray_block import Beams, OnRay, RayBlock, directions
from racecar_sim.sensors.sensor_xml import topic_and_frame
from racecar_sim.sensors.velodyne import CloudPublisher, noise_stddev

PLUGIN = "libgazebo_ros_block_laser.so"
EPSILON_DIFF = 1e-6  # the plugin's: a range this close to the cap is a beam that hit nothing (no noise)


@dataclass(frozen=True)
class BlockLaserSpec(OnRay):
    """A block laser: its ray block's beams, noise, topic and frame."""

    ray: RayBlock
    gaussian_noise: float
    topic: str
    frame_id: str

    @classmethod
    def from_sensor(cls, sensor: Sensor) -> BlockLaserSpec:
        """Read a ray block holding gazebo_ros_block_laser (DescriptionError naming what is wrong)."""
        ray, params, where = RayBlock.read(sensor, PLUGIN, rated=True)
        return cls(ray, noise_stddev(params, where), *topic_and_frame(params, "/world"))


def _shifted(beams: Beams) -> np.ndarray:
    """The angles the plugin puts the beams' points at: halfway to the next beam (the last keeps its own)."""
    index = np.arange(beams.samples)
    return beams.min_angle + beams.step * 0.5 * (index + np.minimum(index + 1, beams.samples - 1))


class BlockLaserPublisher(CloudPublisher):
    """gazebo_ros_block_laser: PointCloud on its topic at the sensor's rate (see the module doc)."""

    def __init__(self, ctx: NodeContext, spec: BlockLaserSpec) -> None:
        self.spec = spec
        ray = spec.ray
        super().__init__(ctx, spec, spec.topic, spec.frame_id, ray.update_rate, "block laser")
        self._local = ray.directions()  # where each beam points (rows of the vertical samples)
        self._placed = directions(_shifted(ray.horizontal), _shifted(ray.vertical), -1.0)  # its point (z down)
        self.noise = ctx.noise and spec.gaussian_noise > 0
        self.noise_table = NoiseTable.shared(ctx.noise_stream(f"block_laser/{spec.name}"), 4 * len(self._local))

    def cloud(self, stamp_ns: int) -> PointCloud:
        """The cloud of a scan taken now, stamped `stamp_ns`."""
        spec, ray = self.spec, self.spec.ray
        cap = ray.range_max - ray.range_min
        r = self.beams.cast(self._local, ray.range_min, ray.range_max)
        r[~np.isfinite(r)] = ray.range_max  # no hit: the ray's full length
        np.minimum(r, cap, out=r)
        xyz = self._placed * r[:, None]
        intensity = np.zeros(len(r))
        if self.noise:
            unit = self.noise_table.sample(self.seed, stamp_ns).reshape(4, -1)
            hit = np.abs(cap - r) >= EPSILON_DIFF
            xyz[hit] += spec.gaussian_noise * unit[:3, hit].T
            intensity += spec.gaussian_noise * unit[3]
        points = [Point32(x, y, z) for x, y, z in xyz.astype(np.float32).tolist()]
        channel = ChannelFloat32("", intensity.astype(np.float32))
        return PointCloud(Header.at(stamp_ns, self.frame_id), points, [channel])
