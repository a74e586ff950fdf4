"""The ROS 2 services the bridge offers, each mapped onto a service of the sim's bus.

The Gazebo ROS 2 API (gazebo_ros for ROS 2: the gazebo_ros_init, gazebo_ros_factory and gazebo_ros_state plugins):
  /spawn_entity (gazebo_msgs/srv/SpawnEntity)        -> /gazebo/spawn_sdf_model (a URDF goes to the car spawner)
  /delete_entity (gazebo_msgs/srv/DeleteEntity)      -> /gazebo/delete_model
  /get_entity_state (gazebo_msgs/srv/GetEntityState) -> /gazebo/get_model_state
  /set_entity_state (gazebo_msgs/srv/SetEntityState) -> /gazebo/set_model_state
  /reset_simulation, /reset_world, /pause_physics, /unpause_physics (std_srvs/srv/Empty) -> /gazebo/<the same>
Each car's controller manager, under the sim's name (/racecar/controller_manager/...), with the ros2_control types:
  list_controllers, list_controller_types, load_controller, unload_controller, switch_controller
  (activate_controllers / deactivate_controllers: ROS 1's start / stop; "running" reads "active", a loaded
  controller that does not run "inactive").

Requests and responses cross the pipe as plain dicts (ros_side.py converts them to and from the real classes).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from racecar_sim.msgs import Point, Pose, Quaternion, Twist, Vector3
from racecar_sim.msgs.controller_manager_msgs import (
    ListControllersRequest,
    ListControllerTypesRequest,
    LoadControllerRequest,
    SwitchControllerRequest,
    UnloadControllerRequest,
)
from racecar_sim.msgs.fields import message_fields
from racecar_sim.msgs.gazebo_msgs import (
    DeleteModelRequest,
    GetModelStateRequest,
    ModelState,
    SetModelStateRequest,
    SpawnModelRequest,
)
from racecar_sim.msgs.std_srvs import EmptyRequest

Plain = dict[str, Any]


@dataclass(frozen=True)
class Service:
    """One ROS 2 service: its name and type there, the bus service it calls, and the two conversions."""

    ros_name: str
    ros_type: str
    sim_name: str
    request: Callable[[Plain], Any]  # the ROS 2 request (as a dict) -> the sim's request
    response: Callable[[Any, Plain], Plain]  # (the sim's response, the ROS 2 request) -> the ROS 2 response


def plain(value: Any) -> Any:
    """A sim message (or a field of one) as dicts, lists and plain values, under the ROS 2 field names."""
    msgtype = getattr(value, "__msgtype__", None)
    if isinstance(msgtype, str):
        return {spec.name: plain(getattr(value, spec.attr)) for spec in message_fields(msgtype) if spec.attr}
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, (list, tuple)):
        return [plain(item) for item in value]
    if isinstance(value, np.generic):
        return value.item()
    return value


def _pose(d: Plain) -> Pose:
    p, o = d.get("position", {}), d.get("orientation", {})
    return Pose(Point(**p), Quaternion(**o)) if o else Pose(Point(**p))


def _twist(d: Plain) -> Twist:
    return Twist(Vector3(**d.get("linear", {})), Vector3(**d.get("angular", {})))


def _model_state(state: Plain) -> ModelState:
    pose, twist = _pose(state.get("pose", {})), _twist(state.get("twist", {}))
    return ModelState(state.get("name", ""), pose, twist, state.get("reference_frame", ""))


def _status(res: Any, _req: Plain) -> Plain:
    return {"success": bool(res.success), "status_message": res.status_message}


def _get_entity_state(res: Any, req: Plain) -> Plain:
    state = {"name": req.get("name", ""), "pose": plain(res.pose), "twist": plain(res.twist)}
    state["reference_frame"] = req.get("reference_frame", "")
    return {"header": plain(res.header), "state": state, "success": bool(res.success)}


def _empty(_res: Any, _req: Plain) -> Plain:
    return {}


def _empty_request(_req: Plain) -> EmptyRequest:
    return EmptyRequest()


GAZEBO: tuple[Service, ...] = (
    Service(
        "/spawn_entity",
        "gazebo_msgs/srv/SpawnEntity",
        "/gazebo/spawn_sdf_model",
        lambda r: SpawnModelRequest(
            r.get("name", ""),
            r.get("xml", ""),
            r.get("robot_namespace", ""),
            _pose(r.get("initial_pose", {})),
            r.get("reference_frame", ""),
        ),
        _status,
    ),
    Service(
        "/delete_entity",
        "gazebo_msgs/srv/DeleteEntity",
        "/gazebo/delete_model",
        lambda r: DeleteModelRequest(r.get("name", "")),
        _status,
    ),
    Service(
        "/get_entity_state",
        "gazebo_msgs/srv/GetEntityState",
        "/gazebo/get_model_state",
        lambda r: GetModelStateRequest(r.get("name", ""), r.get("reference_frame", "")),
        _get_entity_state,
    ),
    Service(
        "/set_entity_state",
        "gazebo_msgs/srv/SetEntityState",
        "/gazebo/set_model_state",
        lambda r: SetModelStateRequest(_model_state(r.get("state", {}))),
        lambda res, _r: {"success": bool(res.success)},
    ),
    *(
        Service(f"/{name}", "std_srvs/srv/Empty", f"/gazebo/{name}", _empty_request, _empty)
        for name in ("reset_simulation", "reset_world", "pause_physics", "unpause_physics")
    ),
)

# --- the controller manager ----------------------------------------------------------------------------------------
STATES = {"running": "active", "stopped": "inactive", "initialized": "inactive"}  # ROS 1 state -> ros2_control's
INTERFACES = {  # a ROS 1 hardware interface -> the ROS 2 command interface it claims on each joint
    "hardware_interface::EffortJointInterface": "effort",
    "hardware_interface::VelocityJointInterface": "velocity",
    "hardware_interface::PositionJointInterface": "position",
}


def _controller_state(c: Any) -> Plain:
    interfaces = [
        f"{joint}/{INTERFACES[r.hardware_interface]}"
        for r in c.claimed_resources
        if r.hardware_interface in INTERFACES
        for joint in r.resources
    ]
    state = STATES.get(c.state, c.state)
    return {
        "name": c.name,
        "state": state,
        "type": c.type,
        "claimed_interfaces": interfaces if state == "active" else [],
        "required_command_interfaces": interfaces,
        "required_state_interfaces": [],
    }


def _switch_request(r: Plain) -> SwitchControllerRequest:
    timeout = r.get("timeout") or {}
    return SwitchControllerRequest(
        list(r.get("activate_controllers", [])),
        list(r.get("deactivate_controllers", [])),
        int(r.get("strictness", 0)),
        bool(r.get("activate_asap", False)),
        float(timeout.get("sec", 0)) + float(timeout.get("nanosec", 0)) * 1e-9,
    )


CONTROLLER_MANAGER: dict[str, tuple[str, Callable[[Plain], Any], Callable[[Any, Plain], Plain]]] = {
    "list_controllers": (
        "controller_manager_msgs/srv/ListControllers",
        lambda r: ListControllersRequest(),
        lambda res, _r: {"controller": [_controller_state(c) for c in res.controller]},
    ),
    "list_controller_types": (
        "controller_manager_msgs/srv/ListControllerTypes",
        lambda r: ListControllerTypesRequest(),
        lambda res, _r: {"types": list(res.types), "base_classes": list(res.base_classes)},
    ),
    "load_controller": (
        "controller_manager_msgs/srv/LoadController",
        lambda r: LoadControllerRequest(r.get("name", "")),
        lambda res, _r: {"ok": bool(res.ok)},
    ),
    "unload_controller": (
        "controller_manager_msgs/srv/UnloadController",
        lambda r: UnloadControllerRequest(r.get("name", "")),
        lambda res, _r: {"ok": bool(res.ok)},
    ),
    "switch_controller": (
        "controller_manager_msgs/srv/SwitchController",
        _switch_request,
        lambda res, _r: {"ok": bool(res.ok), "message": "" if res.ok else "switching the controllers failed"},
    ),
}


def offered(bus_services: list[str]) -> dict[str, Service]:
    """The ROS 2 services (by name) for the services the sim's bus offers now."""
    out: dict[str, Service] = {}
    names = set(bus_services)
    for service in GAZEBO:
        if service.sim_name in names:
            out[service.ros_name] = service
    for name in bus_services:
        head, _, op = name.rpartition("/")
        if head.endswith("/controller_manager") and op in CONTROLLER_MANAGER:
            ros_type, request, response = CONTROLLER_MANAGER[op]
            out[name] = Service(name, ros_type, name, request, response)
    return out
