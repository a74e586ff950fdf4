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

class ListControllerTypesRequest(Message):
    """controller_manager_msgs/ListControllerTypes request (empty)."""

    __msgtype__: ClassVar[str]
    __srvtype__: ClassVar[str]
    def __init__(self) -> None: ...

class ListControllerTypesResponse(Message):
    """The controller types the manager can load, and the base class of each."""

    __msgtype__: ClassVar[str]
    __srvtype__: ClassVar[str]
    types: list[str]
    base_classes: list[str]
    def __init__(
        self,
        types: list[str] = ...,
        base_classes: list[str] = ...,
    ) -> None: ...

class ListControllersRequest(Message):
    """controller_manager_msgs/ListControllers request (empty)."""

    __msgtype__: ClassVar[str]
    __srvtype__: ClassVar[str]
    def __init__(self) -> None: ...

class ListControllersResponse(Message):
    """The loaded controllers, in the order they were loaded."""

    __msgtype__: ClassVar[str]
    __srvtype__: ClassVar[str]
    controller: list[ControllerState]
    def __init__(
        self,
        controller: list[ControllerState] = ...,
    ) -> None: ...

class LoadControllerRequest(Message):
    """Load the controller `name` from its parameters (the car's controller YAML)."""

    __msgtype__: ClassVar[str]
    __srvtype__: ClassVar[str]
    name: str
    def __init__(
        self,
        name: str = ...,
    ) -> None: ...

class LoadControllerResponse(Message):
    """ok: whether the controller was constructed and initialized."""

    __msgtype__: ClassVar[str]
    __srvtype__: ClassVar[str]
    ok: bool
    def __init__(
        self,
        ok: bool = ...,
    ) -> None: ...

class SwitchControllerRequest(Message):
    """Stop `stop_controllers`, then start `start_controllers`, in one control step. strictness: STRICT fails the
    whole switch on any problem (an unknown name, stopping a controller that is not running, starting one that is);
    BEST_EFFORT (and 0, as ros_control defaults it) skips those and does the rest. start_asap and timeout matter for
    hardware that switches interfaces slowly; the simulated hardware switches at once."""

    __msgtype__: ClassVar[str]
    __srvtype__: ClassVar[str]
    BEST_EFFORT: ClassVar[int]
    STRICT: ClassVar[int]
    start_controllers: list[str]
    stop_controllers: list[str]
    strictness: int
    start_asap: bool
    timeout: float
    def __init__(
        self,
        start_controllers: list[str] = ...,
        stop_controllers: list[str] = ...,
        strictness: int = ...,
        start_asap: bool = ...,
        timeout: float = ...,
    ) -> None: ...

class SwitchControllerResponse(Message):
    """ok: whether the switch was done (what counts as success depends on the strictness)."""

    __msgtype__: ClassVar[str]
    __srvtype__: ClassVar[str]
    ok: bool
    def __init__(
        self,
        ok: bool = ...,
    ) -> None: ...

class UnloadControllerRequest(Message):
    """Unload the (stopped) controller `name`."""

    __msgtype__: ClassVar[str]
    __srvtype__: ClassVar[str]
    name: str
    def __init__(
        self,
        name: str = ...,
    ) -> None: ...

class UnloadControllerResponse(Message):
    """ok: whether the controller was unloaded."""

    __msgtype__: ClassVar[str]
    __srvtype__: ClassVar[str]
    ok: bool
    def __init__(
        self,
        ok: bool = ...,
    ) -> None: ...

class ListControllerTypes:
    """The service controller_manager_msgs/srv/ListControllerTypes, rclpy-style: ``ListControllerTypes.Request()``,
    ``ListControllerTypes.Response()``."""

    __srvtype__: ClassVar[str]
    Request = ListControllerTypesRequest
    Response = ListControllerTypesResponse

class ListControllers:
    """The service controller_manager_msgs/srv/ListControllers, rclpy-style: ``ListControllers.Request()``,
    ``ListControllers.Response()``."""

    __srvtype__: ClassVar[str]
    Request = ListControllersRequest
    Response = ListControllersResponse

class LoadController:
    """The service controller_manager_msgs/srv/LoadController, rclpy-style: ``LoadController.Request()``,
    ``LoadController.Response()``."""

    __srvtype__: ClassVar[str]
    Request = LoadControllerRequest
    Response = LoadControllerResponse

class SwitchController:
    """The service controller_manager_msgs/srv/SwitchController, rclpy-style: ``SwitchController.Request()``,
    ``SwitchController.Response()``."""

    __srvtype__: ClassVar[str]
    Request = SwitchControllerRequest
    Response = SwitchControllerResponse

class UnloadController:
    """The service controller_manager_msgs/srv/UnloadController, rclpy-style: ``UnloadController.Request()``,
    ``UnloadController.Response()``."""

    __srvtype__: ClassVar[str]
    Request = UnloadControllerRequest
    Response = UnloadControllerResponse
