"""ROS 2 ``tf2_msgs`` messages: TFMessage."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import ClassVar

from racecar_sim.msgs._base import Message
from racecar_sim.msgs.geometry_msgs import TransformStamped


@dataclass(eq=False, repr=False, slots=True)
class TFMessage(Message):
    """A batch of transforms, as published on ``/tf`` and ``/tf_static``."""

    __msgtype__: ClassVar[str] = "tf2_msgs/msg/TFMessage"

    transforms: list[TransformStamped] = field(default_factory=list)
