"""The Hokuyo as racecar.gazebo declares it: every number read from the Gazebo <sensor type="ray"> block.

Editing the xacro (samples, angles, ranges, noise, pose, rate) changes the simulated scan; a field that
is missing or not a number raises DescriptionError naming it. Defaults are SDF's own: noise mean and
stddev 0 and noise type gaussian when not given, frame = the sensor's link, topic /scan.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from dataclasses import dataclass

from racecar_sim.core.errors import DescriptionError
from racecar_sim.description.urdf import Origin, Sensor
from racecar_sim.sensors.sensor_xml import sensor_number

NOISE_TYPES = ("gaussian", "none")


@dataclass(frozen=True)
class LaserSpec:
    """A planar laser range finder: beams from `min_angle` to `max_angle` (rad) about the sensor's z axis,
    ranges in m, rate in Hz, pose of the ray origin in the `link` frame."""

    name: str
    link: str
    pose: Origin
    update_rate: float
    samples: int
    min_angle: float
    max_angle: float
    range_min: float
    range_max: float
    range_resolution: float  # declared; Gazebo 7 does not apply it, nor do we
    noise_type: str
    noise_mean: float
    noise_stddev: float
    topic: str = "/scan"
    frame_id: str = ""

    @property
    def angle_increment(self) -> float:
        """(max - min) / (samples - 1), as gazebo_ros_laser reports it; 0 for a single beam."""
        return (self.max_angle - self.min_angle) / (self.samples - 1) if self.samples > 1 else 0.0

    @property
    def noisy(self) -> bool:
        """Whether readings get Gaussian noise (or a bias)."""
        return self.noise_type == "gaussian" and (self.noise_stddev > 0 or self.noise_mean != 0)

    @classmethod
    def from_sensor(cls, sensor: Sensor) -> LaserSpec:
        """Read a parsed <sensor type="ray"> (its XML element) into a spec."""
        where = f"<sensor type='ray' name='{sensor.name}'> on link {sensor.link}"
        if sensor.type != "ray":
            raise DescriptionError(f"{where}: not a ray sensor (type '{sensor.type}')")
        el = sensor.element
        ray = _child(el, "ray", where)
        horizontal = _child(_child(ray, "scan", where), "horizontal", where)
        samples = sensor_number(horizontal, "samples", where, integer=True)
        resolution = sensor_number(horizontal, "resolution", where, default=1.0)
        if resolution != 1.0:
            raise DescriptionError(f"{where}: <horizontal><resolution> {resolution:g} is not supported (only 1)")
        vertical = ray.find("scan/vertical")
        if vertical is not None and sensor_number(vertical, "samples", where, default=1.0, integer=True) != 1:
            raise DescriptionError(f"{where}: <vertical><samples> must be 1, this is a planar laser")
        span = _child(ray, "range", where)
        spec = cls(
            sensor.name,
            sensor.link,
            sensor.pose,
            _update_rate(el, where),
            int(samples),
            sensor_number(horizontal, "min_angle", where),
            sensor_number(horizontal, "max_angle", where),
            sensor_number(span, "min", where),
            sensor_number(span, "max", where),
            sensor_number(span, "resolution", where, default=0.0),
            *_noise(ray, where),
            *_plugin(el, sensor),
        )
        spec._check(where)
        return spec

    def _check(self, where: str) -> None:
        if self.samples < 1:
            raise DescriptionError(f"{where}: <samples> must be at least 1, got {self.samples}")
        if not self.min_angle <= self.max_angle:
            raise DescriptionError(f"{where}: <min_angle> {self.min_angle:g} is above <max_angle> {self.max_angle:g}")
        if self.max_angle - self.min_angle > 2 * math.pi + 1e-9:
            raise DescriptionError(f"{where}: <min_angle>..<max_angle> spans more than a full turn")
        if not 0 <= self.range_min < self.range_max:
            raise DescriptionError(
                f"{where}: <range> needs 0 <= <min> < <max>, got <min> {self.range_min:g}, <max> {self.range_max:g}"
            )
        if self.noise_stddev < 0:
            raise DescriptionError(f"{where}: <noise><stddev> must not be negative, got {self.noise_stddev:g}")
        if not self.update_rate > 0:
            raise DescriptionError(f"{where}: <update_rate> must be positive, got {self.update_rate:g}")


def _child(el: ET.Element, tag: str, where: str) -> ET.Element:
    child = el.find(tag)
    if child is None:
        raise DescriptionError(f"{where}: <{tag}> is missing inside <{el.tag}>")
    return child


def _update_rate(el: ET.Element, where: str) -> float:
    if el.find("update_rate") is None:
        raise DescriptionError(f"{where}: <sensor><update_rate> is missing")
    return sensor_number(el, "update_rate", where)


def _noise(ray: ET.Element, where: str) -> tuple[str, float, float]:
    noise = ray.find("noise")
    if noise is None:
        return "none", 0.0, 0.0
    kind = (noise.findtext("type") or "gaussian").strip().lower()
    if kind not in NOISE_TYPES:
        raise DescriptionError(f"{where}: <noise><type> '{kind}' is not one of {', '.join(NOISE_TYPES)}")
    return kind, sensor_number(noise, "mean", where, default=0.0), sensor_number(noise, "stddev", where, default=0.0)


def _plugin(el: ET.Element, sensor: Sensor) -> tuple[str, str]:
    """gazebo_ros_laser's <topicName> and <frameName> (ROS 1 plugin tags), if the block has the plugin."""
    plugin = el.find("plugin")
    topic = (plugin.findtext("topicName") or "").strip() if plugin is not None else ""
    frame = (plugin.findtext("frameName") or "").strip() if plugin is not None else ""
    if topic and not topic.startswith("/"):
        topic = "/" + topic
    return topic or "/scan", frame or sensor.link
