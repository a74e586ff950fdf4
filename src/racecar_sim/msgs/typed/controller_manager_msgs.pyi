# Written by `python -m racecar_sim.msgs.stubs` from msgs/definitions: do not edit.
from typing import ClassVar

from racecar_sim.msgs._base import Message

class ControllerState(Message):
    """controller_manager_msgs/ControllerState (ROS 1 noetic): one loaded controller as list_controllers reports
    it."""

    __msgtype__: ClassVar[str]
    name: str
    state: str
    type: str
    claimed_resources: list[HardwareInterfaceResources]
    def __init__(
        self,
        name: str = ...,
        state: str = ...,
        type: str = ...,
        claimed_resources: list[HardwareInterfaceResources] = ...,
    ) -> None: ...

class HardwareInterfaceResources(Message):
    """controller_manager_msgs/HardwareInterfaceResources (ROS 1 noetic): resources a controller claims on one
    interface."""

    __msgtype__: ClassVar[str]
    hardware_interface: str
    resources: list[str]
    def __init__(
        self,
        hardware_interface: str = ...,
        resources: list[str] = ...,
    ) -> None: ...
