"""The ROS 1 bridge (`--ros`): the sim's topics, services, clock and parameters on a real ROS 1 master.

Debian's rospy runs under the system interpreter, maybe not the sim's, so the bridge is two processes: RosBridge
in the sim, and ros_side.py (a rospy node) under the interpreter that has rospy, talking over a pipe.

The names below are imported on first use (PEP 562): a run without --ros loads none of the bridge.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

_HOMES = {
    "DRAIN_RATE": "bridge",
    "RosBridge": "bridge",
    "INSTALL": "environment",
    "RosUnavailable": "environment",
    "message_path": "environment",
    "ros_available": "environment",
    "ros_python": "environment",
    "RosNodes": "nodes",
}

__all__ = [
    "DRAIN_RATE",
    "INSTALL",
    "RosBridge",
    "RosNodes",
    "RosUnavailable",
    "message_path",
    "ros_available",
    "ros_python",
]

if TYPE_CHECKING:
    from racecar_sim.bridges.ros1.bridge import DRAIN_RATE, RosBridge
    from racecar_sim.bridges.ros1.environment import INSTALL, RosUnavailable, message_path, ros_available, ros_python
    from racecar_sim.bridges.ros1.nodes import RosNodes


def __getattr__(name: str) -> Any:
    home = _HOMES.get(name)
    if home is None:
        raise AttributeError(f"module 'racecar_sim.bridges.ros1' has no attribute {name!r}")
    value = getattr(importlib.import_module(f"racecar_sim.bridges.ros1.{home}"), name)
    globals()[name] = value
    return value
