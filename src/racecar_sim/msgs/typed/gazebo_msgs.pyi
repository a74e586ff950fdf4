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

class DeleteModelRequest(Message):
    """gazebo_msgs/DeleteModel request."""

    __msgtype__: ClassVar[str]
    __srvtype__: ClassVar[str]
    model_name: str
    def __init__(
        self,
        model_name: str = ...,
    ) -> None: ...

class DeleteModelResponse(Message):
    """gazebo_msgs/DeleteModel response."""

    __msgtype__: ClassVar[str]
    __srvtype__: ClassVar[str]
    success: bool
    status_message: str
    def __init__(
        self,
        success: bool = ...,
        status_message: str = ...,
    ) -> None: ...

class GetModelStateRequest(Message):
    """gazebo_msgs/GetModelState request: the model, and the entity whose frame the answer is in ("" = world)."""

    __msgtype__: ClassVar[str]
    __srvtype__: ClassVar[str]
    model_name: str
    relative_entity_name: str
    def __init__(
        self,
        model_name: str = ...,
        relative_entity_name: str = ...,
    ) -> None: ...

class GetModelStateResponse(Message):
    """gazebo_msgs/GetModelState response: header.stamp is the sim time, header.frame_id the relative entity."""

    __msgtype__: ClassVar[str]
    __srvtype__: ClassVar[str]
    header: Header
    pose: Pose
    twist: Twist
    success: bool
    status_message: str
    def __init__(
        self,
        header: Header = ...,
        pose: Pose = ...,
        twist: Twist = ...,
        success: bool = ...,
        status_message: str = ...,
    ) -> None: ...

class GetWorldPropertiesRequest(Message):
    """gazebo_msgs/GetWorldProperties request (no fields)."""

    __msgtype__: ClassVar[str]
    __srvtype__: ClassVar[str]
    def __init__(self) -> None: ...

class GetWorldPropertiesResponse(Message):
    """gazebo_msgs/GetWorldProperties response: sim time (s) and the models in the world."""

    __msgtype__: ClassVar[str]
    __srvtype__: ClassVar[str]
    sim_time: float
    model_names: list[str]
    rendering_enabled: bool
    success: bool
    status_message: str
    def __init__(
        self,
        sim_time: float = ...,
        model_names: list[str] = ...,
        rendering_enabled: bool = ...,
        success: bool = ...,
        status_message: str = ...,
    ) -> None: ...

class SetModelStateRequest(Message):
    """gazebo_msgs/SetModelState request."""

    __msgtype__: ClassVar[str]
    __srvtype__: ClassVar[str]
    model_state: ModelState
    def __init__(
        self,
        model_state: ModelState = ...,
    ) -> None: ...

class SetModelStateResponse(Message):
    """gazebo_msgs/SetModelState response."""

    __msgtype__: ClassVar[str]
    __srvtype__: ClassVar[str]
    success: bool
    status_message: str
    def __init__(
        self,
        success: bool = ...,
        status_message: str = ...,
    ) -> None: ...

class SpawnModelRequest(Message):
    """gazebo_msgs/SpawnModel request (spawn_urdf_model: a URDF; spawn_sdf_model: an SDF model)."""

    __msgtype__: ClassVar[str]
    __srvtype__: ClassVar[str]
    model_name: str
    model_xml: str
    robot_namespace: str
    initial_pose: Pose
    reference_frame: str
    def __init__(
        self,
        model_name: str = ...,
        model_xml: str = ...,
        robot_namespace: str = ...,
        initial_pose: Pose = ...,
        reference_frame: str = ...,
    ) -> None: ...

class SpawnModelResponse(Message):
    """gazebo_msgs/SpawnModel response."""

    __msgtype__: ClassVar[str]
    __srvtype__: ClassVar[str]
    success: bool
    status_message: str
    def __init__(
        self,
        success: bool = ...,
        status_message: str = ...,
    ) -> None: ...

class DeleteModel:
    """The service gazebo_msgs/srv/DeleteModel, rclpy-style: ``DeleteModel.Request()``,
    ``DeleteModel.Response()``."""

    __srvtype__: ClassVar[str]
    Request = DeleteModelRequest
    Response = DeleteModelResponse

class GetModelState:
    """The service gazebo_msgs/srv/GetModelState, rclpy-style: ``GetModelState.Request()``,
    ``GetModelState.Response()``."""

    __srvtype__: ClassVar[str]
    Request = GetModelStateRequest
    Response = GetModelStateResponse

class GetWorldProperties:
    """The service gazebo_msgs/srv/GetWorldProperties, rclpy-style: ``GetWorldProperties.Request()``,
    ``GetWorldProperties.Response()``."""

    __srvtype__: ClassVar[str]
    Request = GetWorldPropertiesRequest
    Response = GetWorldPropertiesResponse

class SetModelState:
    """The service gazebo_msgs/srv/SetModelState, rclpy-style: ``SetModelState.Request()``,
    ``SetModelState.Response()``."""

    __srvtype__: ClassVar[str]
    Request = SetModelStateRequest
    Response = SetModelStateResponse

class SpawnModel:
    """The service gazebo_msgs/srv/SpawnModel, rclpy-style: ``SpawnModel.Request()``, ``SpawnModel.Response()``."""

    __srvtype__: ClassVar[str]
    Request = SpawnModelRequest
    Response = SpawnModelResponse
