# Written by `python -m racecar_sim.msgs.stubs` from msgs/definitions: do not edit.
from typing import ClassVar

from racecar_sim.msgs._base import Message
from racecar_sim.msgs.typed.geometry_msgs import TransformStamped

class TFMessage(Message):
    """The ROS message tf2_msgs/msg/TFMessage, made from its definition."""

    __msgtype__: ClassVar[str]
    transforms: list[TransformStamped]
    def __init__(
        self,
        transforms: list[TransformStamped] = ...,
    ) -> None: ...
