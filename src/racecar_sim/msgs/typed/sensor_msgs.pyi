# Written by `python -m racecar_sim.msgs.stubs` from msgs/definitions: do not edit.
from typing import ClassVar

import numpy as np
import numpy.typing as npt

from racecar_sim.msgs._base import Message
from racecar_sim.msgs.extras import ImageMethods
from racecar_sim.msgs.typed.geometry_msgs import Point32, Quaternion, Vector3
from racecar_sim.msgs.typed.std_msgs import Header

class CameraInfo(Message):
    """The ROS message sensor_msgs/msg/CameraInfo, made from its definition."""

    __msgtype__: ClassVar[str]
    header: Header
    height: int
    width: int
    distortion_model: str
    d: npt.NDArray[np.float64]
    k: npt.NDArray[np.float64]
    r: npt.NDArray[np.float64]
    p: npt.NDArray[np.float64]
    binning_x: int
    binning_y: int
    roi: RegionOfInterest
    def __init__(
        self,
        header: Header = ...,
        height: int = ...,
        width: int = ...,
        distortion_model: str = ...,
        d: npt.NDArray[np.float64] = ...,
        k: npt.NDArray[np.float64] = ...,
        r: npt.NDArray[np.float64] = ...,
        p: npt.NDArray[np.float64] = ...,
        binning_x: int = ...,
        binning_y: int = ...,
        roi: RegionOfInterest = ...,
    ) -> None: ...

class ChannelFloat32(Message):
    """One value per point of a sensor_msgs/PointCloud, named: "intensity", "u", "v", "rgb", ..."""

    __msgtype__: ClassVar[str]
    name: str
    values: npt.NDArray[np.float32]
    def __init__(
        self,
        name: str = ...,
        values: npt.NDArray[np.float32] = ...,
    ) -> None: ...

class CompressedImage(Message):
    """The ROS message sensor_msgs/msg/CompressedImage, made from its definition."""

    __msgtype__: ClassVar[str]
    header: Header
    format: str
    data: bytes | npt.NDArray[np.uint8]
    def __init__(
        self,
        header: Header = ...,
        format: str = ...,
        data: bytes | npt.NDArray[np.uint8] = ...,
    ) -> None: ...

class Image(ImageMethods, Message):
    """The ROS message sensor_msgs/msg/Image, made from its definition."""

    __msgtype__: ClassVar[str]
    header: Header
    height: int
    width: int
    encoding: str
    is_bigendian: int
    step: int
    data: bytes | npt.NDArray[np.uint8]
    def __init__(
        self,
        header: Header = ...,
        height: int = ...,
        width: int = ...,
        encoding: str = ...,
        is_bigendian: int = ...,
        step: int = ...,
        data: bytes | npt.NDArray[np.uint8] = ...,
    ) -> None: ...

class Imu(Message):
    """The ROS message sensor_msgs/msg/Imu, made from its definition."""

    __msgtype__: ClassVar[str]
    header: Header
    orientation: Quaternion
    orientation_covariance: npt.NDArray[np.float64]
    angular_velocity: Vector3
    angular_velocity_covariance: npt.NDArray[np.float64]
    linear_acceleration: Vector3
    linear_acceleration_covariance: npt.NDArray[np.float64]
    def __init__(
        self,
        header: Header = ...,
        orientation: Quaternion = ...,
        orientation_covariance: npt.NDArray[np.float64] = ...,
        angular_velocity: Vector3 = ...,
        angular_velocity_covariance: npt.NDArray[np.float64] = ...,
        linear_acceleration: Vector3 = ...,
        linear_acceleration_covariance: npt.NDArray[np.float64] = ...,
    ) -> None: ...

class JointState(Message):
    """The ROS message sensor_msgs/msg/JointState, made from its definition."""

    __msgtype__: ClassVar[str]
    header: Header
    name: list[str]
    position: npt.NDArray[np.float64]
    velocity: npt.NDArray[np.float64]
    effort: npt.NDArray[np.float64]
    def __init__(
        self,
        header: Header = ...,
        name: list[str] = ...,
        position: npt.NDArray[np.float64] = ...,
        velocity: npt.NDArray[np.float64] = ...,
        effort: npt.NDArray[np.float64] = ...,
    ) -> None: ...

class Joy(Message):
    """The ROS message sensor_msgs/msg/Joy, made from its definition."""

    __msgtype__: ClassVar[str]
    header: Header
    axes: npt.NDArray[np.float32]
    buttons: npt.NDArray[np.int32]
    def __init__(
        self,
        header: Header = ...,
        axes: npt.NDArray[np.float32] = ...,
        buttons: npt.NDArray[np.int32] = ...,
    ) -> None: ...

class LaserScan(Message):
    """The ROS message sensor_msgs/msg/LaserScan, made from its definition."""

    __msgtype__: ClassVar[str]
    header: Header
    angle_min: float
    angle_max: float
    angle_increment: float
    time_increment: float
    scan_time: float
    range_min: float
    range_max: float
    ranges: npt.NDArray[np.float32]
    intensities: npt.NDArray[np.float32]
    def __init__(
        self,
        header: Header = ...,
        angle_min: float = ...,
        angle_max: float = ...,
        angle_increment: float = ...,
        time_increment: float = ...,
        scan_time: float = ...,
        range_min: float = ...,
        range_max: float = ...,
        ranges: npt.NDArray[np.float32] = ...,
        intensities: npt.NDArray[np.float32] = ...,
    ) -> None: ...

class NavSatFix(Message):
    """Navigation Satellite fix for any Global Navigation Satellite System: latitude and longitude in degrees
    (positive north and east), altitude in m above the WGS 84 ellipsoid, position covariance in m^2 (east, north,
    up)."""

    __msgtype__: ClassVar[str]
    COVARIANCE_TYPE_UNKNOWN: ClassVar[int]
    COVARIANCE_TYPE_APPROXIMATED: ClassVar[int]
    COVARIANCE_TYPE_DIAGONAL_KNOWN: ClassVar[int]
    COVARIANCE_TYPE_KNOWN: ClassVar[int]
    header: Header
    status: NavSatStatus
    latitude: float
    longitude: float
    altitude: float
    position_covariance: npt.NDArray[np.float64]
    position_covariance_type: int
    def __init__(
        self,
        header: Header = ...,
        status: NavSatStatus = ...,
        latitude: float = ...,
        longitude: float = ...,
        altitude: float = ...,
        position_covariance: npt.NDArray[np.float64] = ...,
        position_covariance_type: int = ...,
    ) -> None: ...

class NavSatStatus(Message):
    """Navigation Satellite fix status for any Global Navigation Satellite System."""

    __msgtype__: ClassVar[str]
    STATUS_NO_FIX: ClassVar[int]
    STATUS_FIX: ClassVar[int]
    STATUS_SBAS_FIX: ClassVar[int]
    STATUS_GBAS_FIX: ClassVar[int]
    SERVICE_GPS: ClassVar[int]
    SERVICE_GLONASS: ClassVar[int]
    SERVICE_COMPASS: ClassVar[int]
    SERVICE_GALILEO: ClassVar[int]
    status: int
    service: int
    def __init__(
        self,
        status: int = ...,
        service: int = ...,
    ) -> None: ...

class PointCloud(Message):
    """A collection of 3-D points in header.frame_id, each with the values of the channels (one per point in
    each)."""

    __msgtype__: ClassVar[str]
    header: Header
    points: list[Point32]
    channels: list[ChannelFloat32]
    def __init__(
        self,
        header: Header = ...,
        points: list[Point32] = ...,
        channels: list[ChannelFloat32] = ...,
    ) -> None: ...

class PointCloud2(Message):
    """The ROS message sensor_msgs/msg/PointCloud2, made from its definition."""

    __msgtype__: ClassVar[str]
    header: Header
    height: int
    width: int
    fields: list[PointField]
    is_bigendian: bool
    point_step: int
    row_step: int
    data: bytes | npt.NDArray[np.uint8]
    is_dense: bool
    def __init__(
        self,
        header: Header = ...,
        height: int = ...,
        width: int = ...,
        fields: list[PointField] = ...,
        is_bigendian: bool = ...,
        point_step: int = ...,
        row_step: int = ...,
        data: bytes | npt.NDArray[np.uint8] = ...,
        is_dense: bool = ...,
    ) -> None: ...

class PointField(Message):
    """The ROS message sensor_msgs/msg/PointField, made from its definition."""

    __msgtype__: ClassVar[str]
    INT8: ClassVar[int]
    UINT8: ClassVar[int]
    INT16: ClassVar[int]
    UINT16: ClassVar[int]
    INT32: ClassVar[int]
    UINT32: ClassVar[int]
    FLOAT32: ClassVar[int]
    FLOAT64: ClassVar[int]
    name: str
    offset: int
    datatype: int
    count: int
    def __init__(
        self,
        name: str = ...,
        offset: int = ...,
        datatype: int = ...,
        count: int = ...,
    ) -> None: ...

class Range(Message):
    """Single range reading from an active ranger that emits energy and reports one range reading that is valid
    along an arc at the distance measured (sonar, IR): the cone's full angle field_of_view (rad), the range in m,
    and its variance (m^2, 0 when unknown) as Jazzy and Kilted define it (Humble's and ROS 1's have no variance;
    their readers take the fields they know)."""

    __msgtype__: ClassVar[str]
    ULTRASOUND: ClassVar[int]
    INFRARED: ClassVar[int]
    header: Header
    radiation_type: int
    field_of_view: float
    min_range: float
    max_range: float
    range: float
    variance: float
    def __init__(
        self,
        header: Header = ...,
        radiation_type: int = ...,
        field_of_view: float = ...,
        min_range: float = ...,
        max_range: float = ...,
        range: float = ...,
        variance: float = ...,
    ) -> None: ...

class RegionOfInterest(Message):
    """The ROS message sensor_msgs/msg/RegionOfInterest, made from its definition."""

    __msgtype__: ClassVar[str]
    x_offset: int
    y_offset: int
    height: int
    width: int
    do_rectify: bool
    def __init__(
        self,
        x_offset: int = ...,
        y_offset: int = ...,
        height: int = ...,
        width: int = ...,
        do_rectify: bool = ...,
    ) -> None: ...
