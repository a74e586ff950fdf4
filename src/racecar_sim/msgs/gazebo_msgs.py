"""``gazebo_msgs`` (ROS 1 noetic definitions, as gazebo_ros_api_plugin offers them): the state topics and services.

LinkStates and ModelStates are published on ``/gazebo/link_states`` and ``/gazebo/model_states`` and recorded
like every topic; ModelState is also the message of the ``/gazebo/set_model_state`` topic. The services'
request and response classes mirror the ``.srv`` files field for field: ``GetModelStateRequest`` (rospy) is
also ``GetModelState.Request`` (rclpy). They travel only over the in-process bus (``bus.call``), never to a
recording, so they have no ``.msg`` schema.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, ClassVar

from racecar_sim.msgs._base import Message
from racecar_sim.msgs.generate import package_getattr
from racecar_sim.msgs.geometry_msgs import Pose, Twist
from racecar_sim.msgs.std_msgs import Header

if TYPE_CHECKING:
    from racecar_sim.msgs.typed.gazebo_msgs import *  # noqa: F403  # the messages' types, from their definitions
    from racecar_sim.msgs.typed.gazebo_msgs import ModelState

__getattr__ = package_getattr(__name__)
if not TYPE_CHECKING:
    ModelState = __getattr__("ModelState")  # a default of SetModelStateRequest


# --- services (request --- response) ------------------------------------------------------------------------------
@dataclass(eq=False, repr=False, slots=True)
class GetModelStateRequest(Message):
    """gazebo_msgs/GetModelState request: the model, and the entity whose frame the answer is in ("" = world)."""

    __msgtype__: ClassVar[str] = "gazebo_msgs/srv/GetModelState_Request"

    model_name: str = ""
    relative_entity_name: str = ""


@dataclass(eq=False, repr=False, slots=True)
class GetModelStateResponse(Message):
    """gazebo_msgs/GetModelState response: header.stamp is the sim time, header.frame_id the relative entity."""

    __msgtype__: ClassVar[str] = "gazebo_msgs/srv/GetModelState_Response"

    header: Header = field(default_factory=Header)
    pose: Pose = field(default_factory=Pose)
    twist: Twist = field(default_factory=Twist)
    success: bool = False
    status_message: str = ""


@dataclass(eq=False, repr=False, slots=True)
class SetModelStateRequest(Message):
    """gazebo_msgs/SetModelState request."""

    __msgtype__: ClassVar[str] = "gazebo_msgs/srv/SetModelState_Request"

    model_state: ModelState = field(default_factory=ModelState)


@dataclass(eq=False, repr=False, slots=True)
class SetModelStateResponse(Message):
    """gazebo_msgs/SetModelState response."""

    __msgtype__: ClassVar[str] = "gazebo_msgs/srv/SetModelState_Response"

    success: bool = False
    status_message: str = ""


@dataclass(eq=False, repr=False, slots=True)
class SpawnModelRequest(Message):
    """gazebo_msgs/SpawnModel request (spawn_urdf_model: a URDF; spawn_sdf_model: an SDF model)."""

    __msgtype__: ClassVar[str] = "gazebo_msgs/srv/SpawnModel_Request"

    model_name: str = ""
    model_xml: str = ""
    robot_namespace: str = ""
    initial_pose: Pose = field(default_factory=Pose)
    reference_frame: str = ""


@dataclass(eq=False, repr=False, slots=True)
class SpawnModelResponse(Message):
    """gazebo_msgs/SpawnModel response."""

    __msgtype__: ClassVar[str] = "gazebo_msgs/srv/SpawnModel_Response"

    success: bool = False
    status_message: str = ""


@dataclass(eq=False, repr=False, slots=True)
class DeleteModelRequest(Message):
    """gazebo_msgs/DeleteModel request."""

    __msgtype__: ClassVar[str] = "gazebo_msgs/srv/DeleteModel_Request"

    model_name: str = ""


@dataclass(eq=False, repr=False, slots=True)
class DeleteModelResponse(Message):
    """gazebo_msgs/DeleteModel response."""

    __msgtype__: ClassVar[str] = "gazebo_msgs/srv/DeleteModel_Response"

    success: bool = False
    status_message: str = ""


@dataclass(eq=False, repr=False, slots=True)
class GetWorldPropertiesRequest(Message):
    """gazebo_msgs/GetWorldProperties request (no fields)."""

    __msgtype__: ClassVar[str] = "gazebo_msgs/srv/GetWorldProperties_Request"


@dataclass(eq=False, repr=False, slots=True)
class GetWorldPropertiesResponse(Message):
    """gazebo_msgs/GetWorldProperties response: sim time (s) and the models in the world."""

    __msgtype__: ClassVar[str] = "gazebo_msgs/srv/GetWorldProperties_Response"

    sim_time: float = 0.0
    model_names: list[str] = field(default_factory=list)
    rendering_enabled: bool = False
    success: bool = False
    status_message: str = ""


class GetModelState:
    """The service type, rclpy-style: ``GetModelState.Request``, ``GetModelState.Response``."""

    Request = GetModelStateRequest
    Response = GetModelStateResponse


class SetModelState:
    """The service type, rclpy-style."""

    Request = SetModelStateRequest
    Response = SetModelStateResponse


class SpawnModel:
    """The service type, rclpy-style."""

    Request = SpawnModelRequest
    Response = SpawnModelResponse


class DeleteModel:
    """The service type, rclpy-style."""

    Request = DeleteModelRequest
    Response = DeleteModelResponse


class GetWorldProperties:
    """The service type, rclpy-style."""

    Request = GetWorldPropertiesRequest
    Response = GetWorldPropertiesResponse


__all__ = [
    "DeleteModel",
    "DeleteModelRequest",
    "DeleteModelResponse",
    "GetModelState",
    "GetModelStateRequest",
    "GetModelStateResponse",
    "GetWorldProperties",
    "GetWorldPropertiesRequest",
    "GetWorldPropertiesResponse",
    "SetModelState",
    "SetModelStateRequest",
    "SetModelStateResponse",
    "SpawnModel",
    "SpawnModelRequest",
    "SpawnModelResponse",
]
