"""ROS 2 ``geometry_msgs`` messages used by the simulator."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np
import numpy.typing as npt

from racecar_sim.msgs._base import Message
from racecar_sim.msgs.std_msgs import Header


def _covariance() -> npt.NDArray[np.float64]:
    return np.zeros(36, dtype=np.float64)


@dataclass(eq=False, repr=False, slots=True)
class Point(Message):
    """Position in free space, in metres."""

    __msgtype__: ClassVar[str] = "geometry_msgs/msg/Point"

    x: float = 0.0
    y: float = 0.0
    z: float = 0.0


@dataclass(eq=False, repr=False, slots=True)
class Vector3(Message):
    """A vector in free space (m, m/s or rad/s depending on use)."""

    __msgtype__: ClassVar[str] = "geometry_msgs/msg/Vector3"

    x: float = 0.0
    y: float = 0.0
    z: float = 0.0


@dataclass(eq=False, repr=False, slots=True)
class Quaternion(Message):
    """Orientation as a unit quaternion (x, y, z, w); the default is the identity."""

    __msgtype__: ClassVar[str] = "geometry_msgs/msg/Quaternion"

    x: float = 0.0
    y: float = 0.0
    z: float = 0.0
    w: float = 1.0


@dataclass(eq=False, repr=False, slots=True)
class Pose(Message):
    """Position and orientation."""

    __msgtype__: ClassVar[str] = "geometry_msgs/msg/Pose"

    position: Point = field(default_factory=Point)
    orientation: Quaternion = field(default_factory=Quaternion)


@dataclass(eq=False, repr=False, slots=True)
class PoseWithCovariance(Message):
    """Pose with a row-major 6x6 covariance over (x, y, z, roll, pitch, yaw)."""

    __msgtype__: ClassVar[str] = "geometry_msgs/msg/PoseWithCovariance"

    pose: Pose = field(default_factory=Pose)
    covariance: npt.NDArray[np.float64] = field(default_factory=_covariance)


@dataclass(eq=False, repr=False, slots=True)
class PoseStamped(Message):
    """Pose with a header."""

    __msgtype__: ClassVar[str] = "geometry_msgs/msg/PoseStamped"

    header: Header = field(default_factory=Header)
    pose: Pose = field(default_factory=Pose)


@dataclass(eq=False, repr=False, slots=True)
class PoseWithCovarianceStamped(Message):
    """Pose with covariance and a header (RViz's 2D Pose Estimate on /initialpose)."""

    __msgtype__: ClassVar[str] = "geometry_msgs/msg/PoseWithCovarianceStamped"

    header: Header = field(default_factory=Header)
    pose: PoseWithCovariance = field(default_factory=PoseWithCovariance)


@dataclass(eq=False, repr=False, slots=True)
class Twist(Message):
    """Linear (m/s) and angular (rad/s) velocity."""

    __msgtype__: ClassVar[str] = "geometry_msgs/msg/Twist"

    linear: Vector3 = field(default_factory=Vector3)
    angular: Vector3 = field(default_factory=Vector3)


@dataclass(eq=False, repr=False, slots=True)
class TwistWithCovariance(Message):
    """Twist with a row-major 6x6 covariance."""

    __msgtype__: ClassVar[str] = "geometry_msgs/msg/TwistWithCovariance"

    twist: Twist = field(default_factory=Twist)
    covariance: npt.NDArray[np.float64] = field(default_factory=_covariance)


@dataclass(eq=False, repr=False, slots=True)
class Transform(Message):
    """Translation (m) and rotation between two frames."""

    __msgtype__: ClassVar[str] = "geometry_msgs/msg/Transform"

    translation: Vector3 = field(default_factory=Vector3)
    rotation: Quaternion = field(default_factory=Quaternion)


@dataclass(eq=False, repr=False, slots=True)
class TransformStamped(Message):
    """Transform from ``header.frame_id`` to ``child_frame_id`` at ``header.stamp``."""

    __msgtype__: ClassVar[str] = "geometry_msgs/msg/TransformStamped"

    header: Header = field(default_factory=Header)
    child_frame_id: str = ""
    transform: Transform = field(default_factory=Transform)
