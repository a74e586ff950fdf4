# Written by `python -m racecar_sim.msgs.stubs` from msgs/definitions: do not edit.
from typing import ClassVar

import numpy as np
import numpy.typing as npt

from racecar_sim.msgs._base import Message
from racecar_sim.msgs.typed.builtin_interfaces import Time
from racecar_sim.msgs.typed.geometry_msgs import Pose, PoseWithCovariance, TwistWithCovariance
from racecar_sim.msgs.typed.std_msgs import Header

class MapMetaData(Message):
    """The ROS message nav_msgs/msg/MapMetaData, made from its definition."""

    __msgtype__: ClassVar[str]
    map_load_time: Time
    resolution: float
    width: int
    height: int
    origin: Pose
    def __init__(
        self,
        map_load_time: Time = ...,
        resolution: float = ...,
        width: int = ...,
        height: int = ...,
        origin: Pose = ...,
    ) -> None: ...

class OccupancyGrid(Message):
    """The ROS message nav_msgs/msg/OccupancyGrid, made from its definition."""

    __msgtype__: ClassVar[str]
    header: Header
    info: MapMetaData
    data: npt.NDArray[np.int8]
    def __init__(
        self,
        header: Header = ...,
        info: MapMetaData = ...,
        data: npt.NDArray[np.int8] = ...,
    ) -> None: ...

class Odometry(Message):
    """The ROS message nav_msgs/msg/Odometry, made from its definition."""

    __msgtype__: ClassVar[str]
    header: Header
    child_frame_id: str
    pose: PoseWithCovariance
    twist: TwistWithCovariance
    def __init__(
        self,
        header: Header = ...,
        child_frame_id: str = ...,
        pose: PoseWithCovariance = ...,
        twist: TwistWithCovariance = ...,
    ) -> None: ...
