"""A sonar or IR ranger as gazebo_ros_range reads it: a `<sensor type="ray">` block with libgazebo_ros_range.so.

The sensor block gives the beams (<ray><scan><horizontal> and <vertical>: samples, min_angle, max_angle), their span
(<range><min>, <max>) and the rate; the plugin block gives the ROS side, with the plugin's own defaults
(gazebo_plugins/src/gazebo_ros_range.cpp, ROS 1): <topicName> /range, <frameName> /world (tf::resolve drops the
leading slash), <radiation> ultrasound (anything else is infrared), <fov> 0.05 rad, <gaussianNoise> 0, <updateRate>
0 (every sensor update), all under ros::NodeHandle(<robotNamespace>) ("" when absent).
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from dataclasses import dataclass

from racecar_sim.core.errors import DescriptionError
from racecar_sim.description.urdf import Origin, Sensor
from racecar_sim.sensors.sensor_xml import join_topic, plugin_number, sensor_number

PLUGIN = "libgazebo_ros_range.so"
FLT_MAX = 3.4028234663852886e38  # std::numeric_limits<float>::max()
ULTRASOUND, INFRARED = 0, 1  # sensor_msgs/Range's radiation types


@dataclass(frozen=True)
class Beams:
    """One axis of a ray sensor's beams: `samples` angles from `min_angle` to `max_angle` (rad)."""

    samples: int
    min_angle: float
    max_angle: float

    @property
    def step(self) -> float:
        """The angle between neighbouring beams (0 for one beam)."""
        return (self.max_angle - self.min_angle) / (self.samples - 1) if self.samples > 1 else 0.0


@dataclass(frozen=True)
class RangeSpec:
    """A ranger: beams about the sensor's z axis (horizontal) and y axis (vertical), ranges in m, rate in Hz, the pose
    of the ray origin in the `link` frame, and what gazebo_ros_range publishes (topic, frame, radiation, fov)."""

    name: str
    link: str
    pose: Origin
    update_rate: float
    horizontal: Beams
    vertical: Beams
    range_min: float
    range_max: float
    topic: str
    frame_id: str
    radiation_type: int
    field_of_view: float
    gaussian_noise: float
    no_hit: float = math.nan  # the range when no beam hits: FLT_MAX for ROS 2's plugin; nan: range_max (ROS 1's)

    @property
    def nothing_seen(self) -> float:
        """The range published when no beam hits anything within range_max."""
        return self.range_max if math.isnan(self.no_hit) else self.no_hit

    @classmethod
    def from_sensor(cls, sensor: Sensor) -> RangeSpec:
        """Read a `<sensor type="ray">` block holding gazebo_ros_range into a spec (DescriptionError naming what is
        wrong)."""
        where = f"<sensor type='{sensor.type}' name='{sensor.name}'> on link {sensor.link}"
        plugin = next((p for p in sensor.plugins if p.filename == PLUGIN), None)
        if plugin is None:
            raise DescriptionError(f"{where}: no <plugin filename='{PLUGIN}'> inside")
        params = plugin.params
        sensor_rate, horizontal, vertical, range_min, range_max = ray_block(sensor, where)
        plugin_rate = plugin_number(params, "updateRate", where, 0.0)  # a throttle on the sensor's updates
        rates = [r for r in (sensor_rate, plugin_rate) if r > 0]
        if not rates:
            raise DescriptionError(f"{where}: <update_rate> and <updateRate> are 0: give the ranger a rate")
        frame = params.get("frameName") or "/world"
        spec = cls(
            sensor.name,
            sensor.link,
            sensor.pose,
            min(rates),
            horizontal,
            vertical,
            range_min,
            range_max,
            join_topic(params.get("robotNamespace", ""), params.get("topicName") or "/range"),
            frame.lstrip("/"),
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
        where = f"<sensor type='{sensor.type}' name='{sensor.name}'> on link {sensor.link}"
        rate, horizontal, vertical, range_min, range_max = ray_block(sensor, where)
        if radiation not in ("ultrasound", "infrared"):
            raise DescriptionError(f"{where}: <radiation_type> '{radiation}' is not ultrasound or infrared")
        span = max(horizontal.max_angle - horizontal.min_angle, vertical.max_angle - vertical.min_angle)
        return cls(
            sensor.name,
            sensor.link,
            sensor.pose,
            rate,
            horizontal,
            vertical,
            range_min,
            range_max,
            topic,
            frame_id,
            ULTRASOUND if radiation == "ultrasound" else INFRARED,
            span,
            0.0,
            FLT_MAX,
        )


def ray_block(sensor: Sensor, where: str) -> tuple[float, Beams, Beams, float, float]:
    """The ray block's rate, beams (horizontal, vertical) and span (min, max)."""
    ray = sensor.element.find("ray")
    if ray is None:
        raise DescriptionError(f"{where}: <ray> is missing")
    span = ray.find("range")
    if span is None:
        raise DescriptionError(f"{where}: <ray><range> is missing")
    range_min, range_max = sensor_number(span, "min", where), sensor_number(span, "max", where)
    if not 0 <= range_min < range_max:
        got = f"got <min> {range_min:g}, <max> {range_max:g}"
        raise DescriptionError(f"{where}: <range> needs 0 <= <min> < <max>, {got}")
    rate = sensor_number(sensor.element, "update_rate", where, default=0.0)
    return rate, _beams(ray, "horizontal", where), _beams(ray, "vertical", where), range_min, range_max


def _beams(ray: ET.Element, axis: str, where: str) -> Beams:
    el = ray.find(f"scan/{axis}")
    if el is None:  # SDF's defaults: one beam straight ahead
        return Beams(1, 0.0, 0.0)
    samples = int(sensor_number(el, "samples", where, default=1.0, integer=True))
    beams = Beams(samples, sensor_number(el, "min_angle", where, 0.0), sensor_number(el, "max_angle", where, 0.0))
    if samples < 1:
        raise DescriptionError(f"{where}: <{axis}><samples> must be at least 1, got {samples}")
    if not beams.min_angle <= beams.max_angle or beams.max_angle - beams.min_angle > 2 * math.pi:
        raise DescriptionError(
            f"{where}: <{axis}> <min_angle>..<max_angle> is not an increasing span of a turn at most"
        )
    return beams
