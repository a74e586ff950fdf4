# Written by `python -m racecar_sim.msgs.stubs` from msgs/definitions: do not edit.
from typing import ClassVar

from racecar_sim.msgs._base import Message
from racecar_sim.msgs.typed.geometry_msgs import Pose, Twist

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
