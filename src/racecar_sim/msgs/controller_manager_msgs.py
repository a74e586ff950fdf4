"""``controller_manager_msgs`` (ROS 1 noetic): ControllerState and the controller manager's services.

ControllerState and HardwareInterfaceResources are messages (with ``.msg`` definitions and CDR). The services'
requests and responses (ListControllers, ListControllerTypes, LoadController, UnloadController, SwitchController)
are plain dataclasses with the fields of the ``.srv`` files: they travel only through ``Bus.call``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, ClassVar

from racecar_sim.msgs.generate import package_getattr

if TYPE_CHECKING:
    from racecar_sim.msgs.typed.controller_manager_msgs import *  # noqa: F403  # the messages' types
    from racecar_sim.msgs.typed.controller_manager_msgs import ControllerState

__getattr__ = package_getattr(__name__)


@dataclass
class ListControllersRequest:
    """controller_manager_msgs/ListControllers request (empty)."""

    __srvtype__: ClassVar[str] = "controller_manager_msgs/srv/ListControllers"


@dataclass
class ListControllersResponse:
    """The loaded controllers, in the order they were loaded."""

    __srvtype__: ClassVar[str] = "controller_manager_msgs/srv/ListControllers"

    controller: list[ControllerState] = field(default_factory=list)


@dataclass
class ListControllerTypesRequest:
    """controller_manager_msgs/ListControllerTypes request (empty)."""

    __srvtype__: ClassVar[str] = "controller_manager_msgs/srv/ListControllerTypes"


@dataclass
class ListControllerTypesResponse:
    """The controller types the manager can load, and the base class of each."""

    __srvtype__: ClassVar[str] = "controller_manager_msgs/srv/ListControllerTypes"

    types: list[str] = field(default_factory=list)
    base_classes: list[str] = field(default_factory=list)


@dataclass
class LoadControllerRequest:
    """Load the controller `name` from its parameters (the car's controller YAML)."""

    __srvtype__: ClassVar[str] = "controller_manager_msgs/srv/LoadController"

    name: str = ""


@dataclass
class LoadControllerResponse:
    """ok: whether the controller was constructed and initialized."""

    __srvtype__: ClassVar[str] = "controller_manager_msgs/srv/LoadController"

    ok: bool = False


@dataclass
class UnloadControllerRequest:
    """Unload the (stopped) controller `name`."""

    __srvtype__: ClassVar[str] = "controller_manager_msgs/srv/UnloadController"

    name: str = ""


@dataclass
class UnloadControllerResponse:
    """ok: whether the controller was unloaded."""

    __srvtype__: ClassVar[str] = "controller_manager_msgs/srv/UnloadController"

    ok: bool = False


@dataclass
class SwitchControllerRequest:
    """Stop `stop_controllers`, then start `start_controllers`, in one control step.

    strictness: STRICT fails the whole switch on any problem (an unknown name, stopping a controller that is not
    running, starting one that is); BEST_EFFORT (and 0, as ros_control defaults it) skips those and does the rest.
    start_asap and timeout matter for hardware that switches interfaces slowly; the simulated hardware switches at once.
    """

    __srvtype__: ClassVar[str] = "controller_manager_msgs/srv/SwitchController"
    BEST_EFFORT: ClassVar[int] = 1
    STRICT: ClassVar[int] = 2

    start_controllers: list[str] = field(default_factory=list)
    stop_controllers: list[str] = field(default_factory=list)
    strictness: int = 0
    start_asap: bool = False
    timeout: float = 0.0


@dataclass
class SwitchControllerResponse:
    """ok: whether the switch was done (what counts as success depends on the strictness)."""

    __srvtype__: ClassVar[str] = "controller_manager_msgs/srv/SwitchController"

    ok: bool = False
