"""ROS 2's gazebo_ros_ray_sensor with `<output_type>` sensor_msgs/PointCloud2 (its default) or sensor_msgs/PointCloud:
a ray block's beams as a point cloud, as gazebo_ros's conversions (gazebo_ros/conversions/sensor_msgs.hpp) build it.

Beam (i, j) of <horizontal> sample i and <vertical> sample j points along (cos p cos y, cos p sin y, sin p); a beam
that hits nothing within range_max is left out (its range is +inf); every other gives the point r (cos p cos y,
cos p sin y, sin p) with its intensity (0 here: no surface declares a retro-reflectance) clipped below at
<min_intensity> (default 0). PointCloud2: one dense row of x, y, z, intensity (float32 at 0, 4, 8, 12); PointCloud:
Point32s and one channel named "intensity". Topic and frame: the ROS 2 node's `~/out` and gazebo_ros's frame rule
(sensors/ros2_dialect.py). The beams are cast by the 3-D caster (velodyne.BeamCaster) at the end of the last step.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from racecar_sim.msgs.geometry_msgs import Point32
from racecar_sim.msgs.sensor_msgs import ChannelFloat32, PointCloud, PointCloud2, PointField
from racecar_sim.msgs.std_msgs import Header
from racecar_sim.nodes import NodeContext
from racecar_sim.sensors.ray_block import OnRay, RayBlock
from racecar_sim.sensors.velodyne import CloudPublisher

FIELDS = tuple(PointField(name, 4 * i, PointField.FLOAT32, 1) for i, name in enumerate(("x", "y", "z", "intensity")))


@dataclass(frozen=True)
class RayCloudSpec(OnRay):
    """A ray block published as a point cloud by ROS 2's gazebo_ros_ray_sensor."""

    ray: RayBlock
    topic: str
    frame_id: str
    output_type: str  # sensor_msgs/PointCloud2 | sensor_msgs/PointCloud
    min_intensity: float


class RayCloudPublisher(CloudPublisher):
    """gazebo_ros_ray_sensor's point cloud output (see the module doc)."""

    def __init__(self, ctx: NodeContext, spec: RayCloudSpec) -> None:
        self.spec = spec
        ray = spec.ray
        rate = ray.update_rate if ray.update_rate > 0 else 1e9 / ctx.timers.step_ns  # 0: every physics step
        super().__init__(ctx, spec, spec.topic, spec.frame_id, rate, "ray sensor")
        self._local = ray.directions()

    def cloud(self, stamp_ns: int) -> PointCloud2 | PointCloud:
        """The cloud of a scan taken now, stamped `stamp_ns`."""
        spec = self.spec
        r = self.beams.cast(self._local, spec.ray.range_min, spec.ray.range_max)
        hit = np.isfinite(r)
        xyz = (self._local[hit] * r[hit, None]).astype(np.float32)
        intensity = np.full(len(xyz), max(0.0, spec.min_intensity), np.float32)
        header = Header.at(stamp_ns, self.frame_id)
        if spec.output_type == "sensor_msgs/PointCloud":
            points = [Point32(x, y, z) for x, y, z in xyz.tolist()]
            return PointCloud(header, points, [ChannelFloat32("intensity", intensity)])
        data = np.concatenate([xyz, intensity[:, None]], axis=1).astype("<f4")
        n = len(data)
        return PointCloud2(header, 1, n, list(FIELDS), False, 16, 16 * n, data.tobytes(), True)
