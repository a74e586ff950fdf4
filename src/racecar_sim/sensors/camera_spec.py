"""The camera as racecar.gazebo declares it: a Gazebo `<sensor type="camera">` block and its gazebo_ros_camera plugin.

Every number comes from the XML; the intrinsics follow gazebo_ros_camera_utils (fx = fy = w / (2 tan(hfov/2)),
cx = (w+1)/2, cy = (h+1)/2 unless the plugin gives focalLength, Cx, Cy, CxPrime).
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from dataclasses import dataclass

import numpy as np

from racecar_sim.core.errors import DescriptionError
from racecar_sim.description.urdf import Origin, Sensor
from racecar_sim.msgs import CameraInfo, Header
from racecar_sim.sensors.sensor_xml import sensor_number

ENCODINGS = {"B8G8R8": "bgr8", "R8G8B8": "rgb8"}  # SDF image format -> ROS encoding
_DISTORTION = ("distortionK1", "distortionK2", "distortionT1", "distortionT2", "distortionK3")  # plumb_bob order


@dataclass(frozen=True)
class CameraSpec:
    """Everything the camera sensor block says: rate, pose, optics, image, noise, topics."""

    name: str  # the sensor's name, also the MuJoCo camera's
    link: str
    pose: Origin  # in the link frame; the camera looks along the pose's +x, z up (Gazebo's convention)
    rate_hz: float
    hfov: float  # rad
    width: int
    height: int
    encoding: str  # bgr8 | rgb8
    near: float  # m
    far: float  # m
    noise_mean: float  # on the [0, 1] colour scale
    noise_stddev: float
    image_topic: str
    info_topic: str
    frame_id: str
    focal_length: float  # px, CameraInfo fx = fy
    cx: float
    cy: float
    cx_prime: float
    baseline: float  # m, P's Tx = -fx * baseline
    distortion: tuple[float, float, float, float, float]  # k1, k2, t1, t2, k3

    @property
    def fovy(self) -> float:
        """Vertical field of view (rad) of the rendered image: square pixels, the image centred on the axis."""
        return 2.0 * math.atan(math.tan(self.hfov / 2.0) * self.height / self.width)

    @property
    def fx(self) -> float:
        """Focal length in pixels of the rendered image (from hfov)."""
        return self.width / (2.0 * math.tan(self.hfov / 2.0))

    @property
    def step(self) -> int:
        """Bytes per image row."""
        return 3 * self.width

    @classmethod
    def from_sensor(cls, sensor: Sensor, default_format: str | None = None) -> CameraSpec:
        """Read a `<sensor type="camera">` (or "depth"); a missing or invalid field raises DescriptionError naming it.
        `default_format`: the image format when the block gives none (depth blocks often leave it out)."""
        where = f"camera sensor '{sensor.name}' on link {sensor.link}"
        el = sensor.element
        camera = el.find("camera")
        if camera is None:
            raise DescriptionError(f"{where}: <camera> is missing")
        if not (sensor.update_rate > 0 and math.isfinite(sensor.update_rate)):
            raise DescriptionError(f"{where}: <update_rate> must be a positive number, got {sensor.update_rate}")
        hfov = sensor_number(camera, "horizontal_fov", where)
        if not 0 < hfov < math.pi:
            raise DescriptionError(f"{where}: <horizontal_fov> {hfov} must be in (0, pi) rad")
        width, height = (_integer(camera, f"image/{k}", where) for k in ("width", "height"))
        fmt = (
            _text(camera, "image/format", where)
            if default_format is None or camera.find("image/format") is not None
            else default_format
        )
        if fmt not in ENCODINGS:
            raise DescriptionError(f"{where}: <image/format> '{fmt}' is not one of {', '.join(ENCODINGS)}")
        near, far = sensor_number(camera, "clip/near", where), sensor_number(camera, "clip/far", where)
        if not 0 < near < far:
            raise DescriptionError(f"{where}: <clip> needs 0 < near < far, got near {near}, far {far}")
        mean, stddev = _noise(camera, where)
        plugin = _plugin(el)
        namespace = plugin.get("cameraName", camera.get("name", sensor.name))
        focal = _float(plugin, "focalLength", where, 0.0) or width / (2.0 * math.tan(hfov / 2.0))
        cx = _float(plugin, "Cx", where, 0.0) or (width + 1) / 2.0
        return cls(
            name=sensor.name,
            link=sensor.link,
            pose=sensor.pose,
            rate_hz=_rate(sensor, plugin, where),
            hfov=hfov,
            width=width,
            height=height,
            encoding=ENCODINGS[fmt],
            near=near,
            far=far,
            noise_mean=mean,
            noise_stddev=stddev,
            image_topic=_topic(namespace, plugin.get("imageTopicName", "image_raw")),
            info_topic=_topic(namespace, plugin.get("cameraInfoTopicName", "camera_info")),
            frame_id=plugin.get("frameName", sensor.link).lstrip("/") or sensor.link,
            focal_length=focal,
            cx=cx,
            cy=_float(plugin, "Cy", where, 0.0) or (height + 1) / 2.0,
            cx_prime=_float(plugin, "CxPrime", where, 0.0) or cx,
            baseline=_float(plugin, "hackBaseline", where, 0.0),
            distortion=tuple(_float(plugin, k, where, 0.0) for k in _DISTORTION),  # type: ignore[arg-type]
        )

    def camera_info(self, stamp_ns: int) -> CameraInfo:
        """The CameraInfo gazebo_ros_camera publishes beside each image."""
        f = self.focal_length
        return CameraInfo(
            Header.at(stamp_ns, self.frame_id),
            self.height,
            self.width,
            "plumb_bob",
            np.array(self.distortion, dtype=np.float64),
            np.array([f, 0.0, self.cx, 0.0, f, self.cy, 0.0, 0.0, 1.0]),
            np.eye(3).ravel(),
            np.array([f, 0.0, self.cx_prime, -f * self.baseline, 0.0, f, self.cy, 0.0, 0.0, 0.0, 1.0, 0.0]),
        )


def _text(el: ET.Element, path: str, where: str) -> str:
    text = el.findtext(path)
    if text is None or not text.strip():
        raise DescriptionError(f"{where}: <{path}> is missing")
    return text.strip()


def _integer(el: ET.Element, path: str, where: str) -> int:
    value = int(sensor_number(el, path, where, integer=True))
    if value <= 0:
        raise DescriptionError(f"{where}: <{path}> '{value}' is not a positive whole number")
    return value


def _noise(camera: ET.Element, where: str) -> tuple[float, float]:
    noise = camera.find("noise")
    if noise is None:
        return 0.0, 0.0
    kind = (noise.findtext("type") or "gaussian").strip()
    if kind != "gaussian":
        raise DescriptionError(f"{where}: <noise/type> '{kind}' is not supported (only gaussian)")
    mean, stddev = sensor_number(noise, "mean", where + " <noise>"), sensor_number(noise, "stddev", where + " <noise>")
    if stddev < 0:
        raise DescriptionError(f"{where}: <noise/stddev> {stddev} must not be negative")
    return mean, stddev


def _plugin(el: ET.Element) -> dict[str, str]:
    """The gazebo_ros_camera plugin's parameters ({} when the sensor has no plugin)."""
    plugin = el.find("plugin")
    return {} if plugin is None else {c.tag: (c.text or "").strip() for c in plugin}


def _float(plugin: dict[str, str], key: str, where: str, default: float) -> float:
    if key not in plugin:
        return default
    try:
        value = float(plugin[key])
    except ValueError:
        raise DescriptionError(f"{where}: plugin <{key}> '{plugin[key]}' is not a number") from None
    if not math.isfinite(value):
        raise DescriptionError(f"{where}: plugin <{key}> '{plugin[key]}' is not finite")
    return value


def _rate(sensor: Sensor, plugin: dict[str, str], where: str) -> float:
    """The sensor's rate, lowered by the plugin's updateRate if that is smaller (the plugin then skips frames)."""
    plugin_rate = _float(plugin, "updateRate", where, 0.0)
    return min(sensor.update_rate, plugin_rate) if plugin_rate > 0 else sensor.update_rate


def _topic(namespace: str, name: str) -> str:
    return "/" + "/".join(part.strip("/") for part in (namespace, name) if part.strip("/"))
