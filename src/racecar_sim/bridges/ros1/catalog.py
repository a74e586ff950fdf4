"""The ROS 1 types of the services the sim offers, by name.

Configuration as data: a service is typed by its last name component (Gazebo's and the controller manager's keep
their original names in every namespace).
"""

from __future__ import annotations

SERVICE_TYPES: dict[str, str] = {
    "get_model_state": "gazebo_msgs/srv/GetModelState",
    "set_model_state": "gazebo_msgs/srv/SetModelState",
    "spawn_urdf_model": "gazebo_msgs/srv/SpawnModel",
    "spawn_sdf_model": "gazebo_msgs/srv/SpawnModel",
    "delete_model": "gazebo_msgs/srv/DeleteModel",
    "get_world_properties": "gazebo_msgs/srv/GetWorldProperties",
    "pause_physics": "std_srvs/srv/Empty",
    "unpause_physics": "std_srvs/srv/Empty",
    "reset_simulation": "std_srvs/srv/Empty",
    "reset_world": "std_srvs/srv/Empty",
    "list_controllers": "controller_manager_msgs/srv/ListControllers",
    "list_controller_types": "controller_manager_msgs/srv/ListControllerTypes",
    "load_controller": "controller_manager_msgs/srv/LoadController",
    "unload_controller": "controller_manager_msgs/srv/UnloadController",
    "switch_controller": "controller_manager_msgs/srv/SwitchController",
}


def service_type(name: str) -> str | None:
    """The `pkg/srv/Name` type of a service the sim offers, or None if it has no ROS 1 counterpart."""
    return SERVICE_TYPES.get(name.rsplit("/", 1)[-1])
