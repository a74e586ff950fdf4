# Written by `python -m racecar_sim.msgs.stubs` from msgs/definitions: do not edit.
from typing import ClassVar

import numpy as np
import numpy.typing as npt

from racecar_sim.msgs._base import Message
from racecar_sim.msgs.typed.geometry_msgs import Pose, Twist, Vector3, Wrench
from racecar_sim.msgs.typed.std_msgs import Header

class ContactState(Message):
    """The contacts between two collision bodies (gazebo_ros_bumper): the wrench on collision1 at each contact
    point, their sum, the points, the normals and the depths of interpenetration."""

    __msgtype__: ClassVar[str]
    info: str
    collision1_name: str
    collision2_name: str
    wrenches: list[Wrench]
    total_wrench: Wrench
    contact_positions: list[Vector3]
    contact_normals: list[Vector3]
    depths: npt.NDArray[np.float64]
    def __init__(
        self,
        info: str = ...,
        collision1_name: str = ...,
        collision2_name: str = ...,
        wrenches: list[Wrench] = ...,
        total_wrench: Wrench = ...,
        contact_positions: list[Vector3] = ...,
        contact_normals: list[Vector3] = ...,
        depths: npt.NDArray[np.float64] = ...,
    ) -> None: ...

class ContactsState(Message):
    """Every contact a contact sensor's collision has at one update (gazebo_ros_bumper)."""

    __msgtype__: ClassVar[str]
    header: Header
    states: list[ContactState]
    def __init__(
        self,
        header: Header = ...,
        states: list[ContactState] = ...,
    ) -> None: ...

class LinkStates(Message):
    """broadcast all link states in world frame"""

    __msgtype__: ClassVar[str]
    name: list[str]
    pose: list[Pose]
    twist: list[Twist]
    def __init__(
        self,
        name: list[str] = ...,
        pose: list[Pose] = ...,
        twist: list[Twist] = ...,
    ) -> None: ...

class ModelState(Message):
    """Set Gazebo Model pose and twist"""

    __msgtype__: ClassVar[str]
    model_name: str
    pose: Pose
    twist: Twist
    reference_frame: str
    def __init__(
        self,
        model_name: str = ...,
        pose: Pose = ...,
        twist: Twist = ...,
        reference_frame: str = ...,
    ) -> None: ...

class ModelStates(Message):
    """broadcast all model states in world frame"""

    __msgtype__: ClassVar[str]
    name: list[str]
    pose: list[Pose]
    twist: list[Twist]
    def __init__(
        self,
        name: list[str] = ...,
        pose: list[Pose] = ...,
        twist: list[Twist] = ...,
    ) -> None: ...
