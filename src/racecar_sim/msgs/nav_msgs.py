"""ROS 2 ``nav_msgs`` messages: Odometry, OccupancyGrid and its MapMetaData."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np
import numpy.typing as npt

from racecar_sim.msgs._base import Message
from racecar_sim.msgs.builtin_interfaces import Time
from racecar_sim.msgs.geometry_msgs import Pose, PoseWithCovariance, TwistWithCovariance
from racecar_sim.msgs.std_msgs import Header


@dataclass(eq=False, repr=False, slots=True)
class Odometry(Message):
    """Pose in ``header.frame_id`` and twist in ``child_frame_id``, with covariances."""

    __msgtype__: ClassVar[str] = "nav_msgs/msg/Odometry"

    header: Header = field(default_factory=Header)
    child_frame_id: str = ""
    pose: PoseWithCovariance = field(default_factory=PoseWithCovariance)
    twist: TwistWithCovariance = field(default_factory=TwistWithCovariance)


@dataclass(eq=False, repr=False, slots=True)
class MapMetaData(Message):
    """A grid map's size (cells), resolution (m per cell) and the pose of its cell (0, 0)'s outer corner."""

    __msgtype__: ClassVar[str] = "nav_msgs/msg/MapMetaData"

    map_load_time: Time = field(default_factory=Time)
    resolution: float = 0.0
    width: int = 0
    height: int = 0
    origin: Pose = field(default_factory=Pose)


def _no_cells() -> npt.NDArray[np.int8]:
    return np.zeros(0, dtype=np.int8)


@dataclass(eq=False, repr=False, slots=True)
class OccupancyGrid(Message):
    """A 2-D grid map, row-major from cell (0, 0): 0 free, 100 occupied, -1 unknown."""

    __msgtype__: ClassVar[str] = "nav_msgs/msg/OccupancyGrid"

    header: Header = field(default_factory=Header)
    info: MapMetaData = field(default_factory=MapMetaData)
    data: npt.NDArray[np.int8] = field(default_factory=_no_cells)
