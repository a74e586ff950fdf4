# Written by `python -m racecar_sim.msgs.stubs` from msgs/definitions: do not edit.
from typing import ClassVar

import numpy as np
import numpy.typing as npt

from racecar_sim.msgs._base import Message
from racecar_sim.msgs.typed.std_msgs import Header

class Point(Message):
    """The ROS message geometry_msgs/msg/Point, made from its definition."""

    __msgtype__: ClassVar[str]
    x: float
    y: float
    z: float
    def __init__(
        self,
        x: float = ...,
        y: float = ...,
        z: float = ...,
    ) -> None: ...

class Point32(Message):
    """A point in free space, float32 (for many points: sensor_msgs/PointCloud)."""

    __msgtype__: ClassVar[str]
    x: float
    y: float
    z: float
    def __init__(
        self,
        x: float = ...,
        y: float = ...,
        z: float = ...,
    ) -> None: ...

class Pose(Message):
    """The ROS message geometry_msgs/msg/Pose, made from its definition."""

    __msgtype__: ClassVar[str]
    position: Point
    orientation: Quaternion
    def __init__(
        self,
        position: Point = ...,
        orientation: Quaternion = ...,
    ) -> None: ...

class PoseStamped(Message):
    """The ROS message geometry_msgs/msg/PoseStamped, made from its definition."""

    __msgtype__: ClassVar[str]
    header: Header
    pose: Pose
    def __init__(
        self,
        header: Header = ...,
        pose: Pose = ...,
    ) -> None: ...

class PoseWithCovariance(Message):
    """The ROS message geometry_msgs/msg/PoseWithCovariance, made from its definition."""

    __msgtype__: ClassVar[str]
    pose: Pose
    covariance: npt.NDArray[np.float64]
    def __init__(
        self,
        pose: Pose = ...,
        covariance: npt.NDArray[np.float64] = ...,
    ) -> None: ...

class PoseWithCovarianceStamped(Message):
    """The ROS message geometry_msgs/msg/PoseWithCovarianceStamped, made from its definition."""

    __msgtype__: ClassVar[str]
    header: Header
    pose: PoseWithCovariance
    def __init__(
        self,
        header: Header = ...,
        pose: PoseWithCovariance = ...,
    ) -> None: ...

class Quaternion(Message):
    """The ROS message geometry_msgs/msg/Quaternion, made from its definition."""

    __msgtype__: ClassVar[str]
    x: float
    y: float
    z: float
    w: float
    def __init__(
        self,
        x: float = ...,
        y: float = ...,
        z: float = ...,
        w: float = ...,
    ) -> None: ...

class Transform(Message):
    """The ROS message geometry_msgs/msg/Transform, made from its definition."""

    __msgtype__: ClassVar[str]
    translation: Vector3
    rotation: Quaternion
    def __init__(
        self,
        translation: Vector3 = ...,
        rotation: Quaternion = ...,
    ) -> None: ...

class TransformStamped(Message):
    """The ROS message geometry_msgs/msg/TransformStamped, made from its definition."""

    __msgtype__: ClassVar[str]
    header: Header
    child_frame_id: str
    transform: Transform
    def __init__(
        self,
        header: Header = ...,
        child_frame_id: str = ...,
        transform: Transform = ...,
    ) -> None: ...

class Twist(Message):
    """The ROS message geometry_msgs/msg/Twist, made from its definition."""

    __msgtype__: ClassVar[str]
    linear: Vector3
    angular: Vector3
    def __init__(
        self,
        linear: Vector3 = ...,
        angular: Vector3 = ...,
    ) -> None: ...

class TwistWithCovariance(Message):
    """The ROS message geometry_msgs/msg/TwistWithCovariance, made from its definition."""

    __msgtype__: ClassVar[str]
    twist: Twist
    covariance: npt.NDArray[np.float64]
    def __init__(
        self,
        twist: Twist = ...,
        covariance: npt.NDArray[np.float64] = ...,
    ) -> None: ...

class Vector3(Message):
    """The ROS message geometry_msgs/msg/Vector3, made from its definition."""

    __msgtype__: ClassVar[str]
    x: float
    y: float
    z: float
    def __init__(
        self,
        x: float = ...,
        y: float = ...,
        z: float = ...,
    ) -> None: ...

class Vector3Stamped(Message):
    """A vector with a reference frame and a timestamp."""

    __msgtype__: ClassVar[str]
    header: Header
    vector: Vector3
    def __init__(
        self,
        header: Header = ...,
        vector: Vector3 = ...,
    ) -> None: ...

class Wrench(Message):
    """A force (N) and a torque (N m) in free space, separated into their linear and angular parts."""

    __msgtype__: ClassVar[str]
    force: Vector3
    torque: Vector3
    def __init__(
        self,
        force: Vector3 = ...,
        torque: Vector3 = ...,
    ) -> None: ...
