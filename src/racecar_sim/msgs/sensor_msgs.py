"""ROS 2 ``sensor_msgs`` messages: JointState, LaserScan, Image, CompressedImage, CameraInfo, RegionOfInterest, Imu,
PointField, PointCloud2, Joy."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np
import numpy.typing as npt

from racecar_sim.msgs._base import Message
from racecar_sim.msgs.geometry_msgs import Quaternion, Vector3
from racecar_sim.msgs.std_msgs import Header


def _f32() -> npt.NDArray[np.float32]:
    return np.zeros(0, dtype=np.float32)


def _f64() -> npt.NDArray[np.float64]:
    return np.zeros(0, dtype=np.float64)


@dataclass(eq=False, repr=False, slots=True)
class JointState(Message):
    """Per-joint position (rad or m), velocity (rad/s or m/s) and effort (N·m or N)."""

    __msgtype__: ClassVar[str] = "sensor_msgs/msg/JointState"

    header: Header = field(default_factory=Header)
    name: list[str] = field(default_factory=list)
    position: npt.NDArray[np.float64] = field(default_factory=_f64)
    velocity: npt.NDArray[np.float64] = field(default_factory=_f64)
    effort: npt.NDArray[np.float64] = field(default_factory=_f64)


@dataclass(eq=False, repr=False, slots=True)
class Joy(Message):
    """A joystick's axes (-1 to 1; joy_node: stick up and stick left positive) and buttons (0 or 1)."""

    __msgtype__: ClassVar[str] = "sensor_msgs/msg/Joy"

    header: Header = field(default_factory=Header)
    axes: npt.NDArray[np.float32] = field(default_factory=_f32)
    buttons: npt.NDArray[np.int32] = field(default_factory=lambda: np.zeros(0, dtype=np.int32))


@dataclass(eq=False, repr=False, slots=True)
class LaserScan(Message):
    """One sweep of a planar range finder: angles in rad, times in s, ranges in m."""

    __msgtype__: ClassVar[str] = "sensor_msgs/msg/LaserScan"

    header: Header = field(default_factory=Header)
    angle_min: float = 0.0
    angle_max: float = 0.0
    angle_increment: float = 0.0
    time_increment: float = 0.0
    scan_time: float = 0.0
    range_min: float = 0.0
    range_max: float = 0.0
    ranges: npt.NDArray[np.float32] = field(default_factory=_f32)
    intensities: npt.NDArray[np.float32] = field(default_factory=_f32)


@dataclass(eq=False, repr=False, slots=True)
class Image(Message):
    """An uncompressed image; ``data`` holds ``height * step`` bytes."""

    __msgtype__: ClassVar[str] = "sensor_msgs/msg/Image"

    header: Header = field(default_factory=Header)
    height: int = 0
    width: int = 0
    encoding: str = ""
    is_bigendian: int = 0
    step: int = 0
    data: bytes | npt.NDArray[np.uint8] = b""  # the cameras publish their pixel array as it is

    def bgr_pixels(self) -> np.ndarray:
        """A bgr8 / rgb8 image's pixels as a (height, width, 3) uint8 array in BGR order (a view where it can be)."""
        rows = np.frombuffer(self.data, np.uint8).reshape(self.height, self.step)[:, : self.width * 3]
        pixels = rows.reshape(self.height, self.width, 3)
        return pixels[:, :, ::-1] if self.encoding == "rgb8" else pixels


@dataclass(eq=False, repr=False, slots=True)
class CompressedImage(Message):
    """An image in a compressed file format (``data``: a JPEG or PNG file's bytes); ``format`` names it as
    image_transport's compressed plugin does, e.g. ``bgr8; jpeg compressed bgr8``."""

    __msgtype__: ClassVar[str] = "sensor_msgs/msg/CompressedImage"

    header: Header = field(default_factory=Header)
    format: str = ""
    data: bytes = b""


@dataclass(eq=False, repr=False, slots=True)
class RegionOfInterest(Message):
    """A rectangular sub-window of an image, in pixels."""

    __msgtype__: ClassVar[str] = "sensor_msgs/msg/RegionOfInterest"

    x_offset: int = 0
    y_offset: int = 0
    height: int = 0
    width: int = 0
    do_rectify: bool = False


def _k() -> npt.NDArray[np.float64]:
    return np.zeros(9, dtype=np.float64)


def _p() -> npt.NDArray[np.float64]:
    return np.zeros(12, dtype=np.float64)


@dataclass(eq=False, repr=False, slots=True)
class CameraInfo(Message):
    """Pinhole calibration: distortion ``d``, row-major ``k`` (3x3), ``r`` (3x3), ``p`` (3x4)."""

    __msgtype__: ClassVar[str] = "sensor_msgs/msg/CameraInfo"

    header: Header = field(default_factory=Header)
    height: int = 0
    width: int = 0
    distortion_model: str = ""
    d: npt.NDArray[np.float64] = field(default_factory=_f64)
    k: npt.NDArray[np.float64] = field(default_factory=_k)
    r: npt.NDArray[np.float64] = field(default_factory=_k)
    p: npt.NDArray[np.float64] = field(default_factory=_p)
    binning_x: int = 0
    binning_y: int = 0
    roi: RegionOfInterest = field(default_factory=RegionOfInterest)


@dataclass(eq=False, repr=False, slots=True)
class Imu(Message):
    """An inertial measurement: orientation (in the world, REP 145), angular velocity (rad/s) and linear acceleration
    (m/s^2, the proper acceleration: +9.81 up at rest) in the sensor frame, each with a row-major 3x3 covariance."""

    __msgtype__: ClassVar[str] = "sensor_msgs/msg/Imu"

    header: Header = field(default_factory=Header)
    orientation: Quaternion = field(default_factory=Quaternion)
    orientation_covariance: npt.NDArray[np.float64] = field(default_factory=_k)
    angular_velocity: Vector3 = field(default_factory=Vector3)
    angular_velocity_covariance: npt.NDArray[np.float64] = field(default_factory=_k)
    linear_acceleration: Vector3 = field(default_factory=Vector3)
    linear_acceleration_covariance: npt.NDArray[np.float64] = field(default_factory=_k)


@dataclass(eq=False, repr=False, slots=True)
class PointField(Message):
    """One field of a PointCloud2 point: its name, byte offset, datatype (FLOAT32 = 7, ...) and element count."""

    __msgtype__: ClassVar[str] = "sensor_msgs/msg/PointField"
    INT8: ClassVar[int] = 1
    UINT8: ClassVar[int] = 2
    INT16: ClassVar[int] = 3
    UINT16: ClassVar[int] = 4
    INT32: ClassVar[int] = 5
    UINT32: ClassVar[int] = 6
    FLOAT32: ClassVar[int] = 7
    FLOAT64: ClassVar[int] = 8

    name: str = ""
    offset: int = 0
    datatype: int = 0
    count: int = 0


@dataclass(eq=False, repr=False, slots=True)
class PointCloud2(Message):
    """Points as packed records (``point_step`` bytes each, laid out by ``fields``), ``height`` rows of ``width``."""

    __msgtype__: ClassVar[str] = "sensor_msgs/msg/PointCloud2"

    header: Header = field(default_factory=Header)
    height: int = 0
    width: int = 0
    fields: list[PointField] = field(default_factory=list)
    is_bigendian: bool = False
    point_step: int = 0
    row_step: int = 0
    data: bytes = b""
    is_dense: bool = False
