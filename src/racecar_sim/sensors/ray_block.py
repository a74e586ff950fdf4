"""What a `<sensor type="ray">` (or "gpu_ray") block says of its beams, read once for every kind built on it (the
ranger, the 3-D lidars, ROS 2's ray sensor clouds): the rate, the horizontal and vertical samples, the span.

Beam (i, j) of horizontal sample i and vertical sample j points along (cos p cos y, cos p sin y, sin p) in the sensor
frame, as Gazebo's ray shape lays its rays out (rows of the vertical samples, lowest first).
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from dataclasses import dataclass

import numpy as np

from racecar_sim.core.errors import DescriptionError
from racecar_sim.description.urdf import Origin, Sensor
from racecar_sim.sensors.sensor_xml import sensor_number


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

    @property
    def angles(self) -> np.ndarray:
        """Every beam's angle (rad)."""
        return self.min_angle + self.step * np.arange(self.samples)


@dataclass(frozen=True)
class RayBlock:
    """A ray block's beams: rate (Hz; 0: every physics step), samples, span (m), and where they start (the pose of the
    ray origin in the `link` frame)."""

    name: str
    link: str
    pose: Origin
    update_rate: float
    horizontal: Beams
    vertical: Beams
    range_min: float
    range_max: float

    @classmethod
    def read(cls, sensor: Sensor, plugin_file: str, rated: bool = False) -> tuple[RayBlock, dict[str, str], str]:
        """The block's beams, the parameters of its `plugin_file` plugin and the block's name for errors
        (DescriptionError naming what is missing or wrong; `rated`: the block must give a positive <update_rate>)."""
        where = f"<sensor type='{sensor.type}' name='{sensor.name}'> on link {sensor.link}"
        plugin = next((p for p in sensor.plugins if p.filename == plugin_file), None)
        if plugin is None:
            raise DescriptionError(f"{where}: no <plugin filename='{plugin_file}'> inside")
        ray = cls.from_sensor(sensor)
        if rated and ray.update_rate <= 0:
            raise DescriptionError(f"{where}: <update_rate> must be positive, got {ray.update_rate:g}")
        return ray, plugin.params, where

    @classmethod
    def from_sensor(cls, sensor: Sensor) -> RayBlock:
        """The block's beams (DescriptionError naming what is missing or wrong)."""
        where = f"<sensor type='{sensor.type}' name='{sensor.name}'> on link {sensor.link}"
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
        if rate < 0:
            raise DescriptionError(f"{where}: <update_rate> must not be negative, got {rate:g}")
        return cls(
            sensor.name,
            sensor.link,
            sensor.pose,
            rate,
            _beams(ray, "horizontal", where),
            _beams(ray, "vertical", where),
            range_min,
            range_max,
        )

    def directions(self) -> np.ndarray:
        """The beams' unit directions in the sensor frame, row by row of the vertical samples ((n, 3))."""
        return directions(self.horizontal.angles, self.vertical.angles)


def directions(yaw: np.ndarray, pitch: np.ndarray, up: float = 1.0) -> np.ndarray:
    """Unit directions (cos p cos y, cos p sin y, up sin p), rows of pitch each every yaw, flattened to (n, 3)."""
    cp, sp = np.cos(pitch)[:, None], np.sin(pitch)[:, None]
    grid = np.stack([cp * np.cos(yaw), cp * np.sin(yaw), np.broadcast_to(up * sp, (len(pitch), len(yaw)))], axis=-1)
    return grid.reshape(-1, 3)


class OnRay:
    """A spec built on a ray block (`ray`): its name, link and pose are the block's."""

    __slots__ = ()
    ray: RayBlock

    @property
    def name(self) -> str:
        """The sensor's name."""
        return self.ray.name

    @property
    def link(self) -> str:
        """The link the sensor is on."""
        return self.ray.link

    @property
    def pose(self) -> Origin:
        """The ray origin's pose in the link frame."""
        return self.ray.pose


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
