"""A sonar or IR ranger as gazebo_ros_range reads it: a `<sensor type="ray">` block with libgazebo_ros_range.so.

The sensor block gives the beams (<ray><scan><horizontal> and <vertical>: samples, min_angle, max_angle), their span
(<range><min>, <max>) and the rate (sensors/ray_block.py); the plugin block gives the ROS side, with the plugin's own
defaults (gazebo_plugins/src/gazebo_ros_range.cpp, ROS 1): <topicName> /range, <frameName> /world (tf::resolve drops
the leading slash), <radiation> ultrasound (anything else is infrared), <fov> 0.05 rad, <gaussianNoise> 0,
<updateRate> 0 (every sensor update), all under ros::NodeHandle(<robotNamespace>) ("" when absent).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

from racecar_sim.core.errors import DescriptionError
from racecar_sim.description.urdf import Sensor
from racecar_sim.sensors.ray_block import OnRay, RayBlock
from racecar_sim.sensors.sensor_xml import plugin_number, topic_and_frame

PLUGIN = "libgazebo_ros_range.so"
FLT_MAX = 3.4028234663852886e38  # std::numeric_limits<float>::max()
ULTRASOUND, INFRARED = 0, 1  # sensor_msgs/Range's radiation types


@dataclass(frozen=True)
class RangeSpec(OnRay):
    """A ranger: its ray block's beams, and what the plugin publishes (topic, frame, radiation, field of view, noise,
    and the range when no beam hits)."""

    ray: RayBlock
    topic: str
    frame_id: str
    radiation_type: int
    field_of_view: float
    gaussian_noise: float
    no_hit: float = math.nan  # the range when no beam hits: FLT_MAX for ROS 2's plugin; nan: range_max (ROS 1's)

    @property
    def nothing_seen(self) -> float:
        """The range published when no beam hits anything within range_max."""
        return self.ray.range_max if math.isnan(self.no_hit) else self.no_hit

    @classmethod
    def from_sensor(cls, sensor: Sensor) -> RangeSpec:
        """Read a `<sensor type="ray">` block holding gazebo_ros_range into a spec (DescriptionError naming what is
        wrong)."""
        ray, params, where = RayBlock.read(sensor, PLUGIN)
        plugin_rate = plugin_number(params, "updateRate", where, 0.0)  # a throttle on the sensor's updates
        rates = [r for r in (ray.update_rate, plugin_rate) if r > 0]
        if not rates:
            raise DescriptionError(f"{where}: <update_rate> and <updateRate> are 0: give the ranger a rate")
        spec = cls(
            replace(ray, update_rate=min(rates)),
            *topic_and_frame(params, "/range"),
            ULTRASOUND if params.get("radiation", "ultrasound") == "ultrasound" else INFRARED,
            plugin_number(params, "fov", where, 0.05),
            plugin_number(params, "gaussianNoise", where, 0.0),
        )
        if spec.gaussian_noise < 0:
            raise DescriptionError(f"{where}: <gaussianNoise> must not be negative, got {spec.gaussian_noise:g}")
        return spec

    @classmethod
    def from_ros2(cls, sensor: Sensor, topic: str, frame_id: str, radiation: str) -> RangeSpec:
        """A `<sensor type="ray">` block with ROS 2's gazebo_ros_ray_sensor and `<output_type>sensor_msgs/Range`: as
        gazebo_ros's conversion fills it, the field of view is the wider of the beams' spans, the range the nearest
        beam's, FLT_MAX when none hits (its first value), and <radiation_type> defaults to infrared."""
        ray = RayBlock.from_sensor(sensor)
        if radiation not in ("ultrasound", "infrared"):
            where = f"<sensor type='{sensor.type}' name='{sensor.name}'> on link {sensor.link}"
            raise DescriptionError(f"{where}: <radiation_type> '{radiation}' is not ultrasound or infrared")
        h, v = ray.horizontal, ray.vertical
        span = max(h.max_angle - h.min_angle, v.max_angle - v.min_angle)
        kind = ULTRASOUND if radiation == "ultrasound" else INFRARED
        return cls(ray, topic, frame_id, kind, span, 0.0, FLT_MAX)
