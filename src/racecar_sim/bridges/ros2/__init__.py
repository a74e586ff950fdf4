"""The ROS 2 bridge (`--ros2`): the sim's topics, services and clock on a ROS 2 graph, as an rclpy node `racecar_sim`.

rclpy comes with a ROS 2 install or the ROS 2 wheels, maybe not for the sim's interpreter, so the bridge is two
processes: Ros2Bridge in the sim, and ros_side.py (an rclpy node on Fast DDS) under the Python that has rclpy, talking
over a pipe (bridges/link.py). Messages cross as the sim's own CDR bytes.

The names below are imported on first use (PEP 562): a run without --ros2 loads none of the bridge.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

_HOMES = {
    "DRAIN_RATE": "bridge",
    "NODE_NAME": "bridge",
    "Ros2Bridge": "bridge",
    "INSTALL": "environment",
    "Ros2Unavailable": "environment",
    "RosPython": "environment",
    "ros2_available": "environment",
    "ros2_environment": "environment",
    "ros2_python": "environment",
}

__all__ = [
    "DRAIN_RATE",
    "INSTALL",
    "NODE_NAME",
    "Ros2Bridge",
    "Ros2Unavailable",
    "RosPython",
    "ros2_available",
    "ros2_environment",
    "ros2_python",
]

if TYPE_CHECKING:
    from racecar_sim.bridges.ros2.bridge import DRAIN_RATE, NODE_NAME, Ros2Bridge
    from racecar_sim.bridges.ros2.environment import (
        INSTALL,
        Ros2Unavailable,
        RosPython,
        ros2_available,
        ros2_environment,
        ros2_python,
    )


def __getattr__(name: str) -> Any:
    home = _HOMES.get(name)
    if home is None:
        raise AttributeError(f"module 'racecar_sim.bridges.ros2' has no attribute {name!r}")
    value = getattr(importlib.import_module(f"racecar_sim.bridges.ros2.{home}"), name)
    globals()[name] = value
    return value
