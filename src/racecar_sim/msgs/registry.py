"""Lookup between ROS 2 type names and the message classes of this package."""

from __future__ import annotations

import importlib
from functools import cache
from typing import Any

from racecar_sim.msgs.idl import normalize_msgtype

# One module per ROS package, named after it.
PACKAGES = (
    "ackermann_msgs",
    "builtin_interfaces",
    "control_msgs",
    "controller_manager_msgs",
    "gazebo_msgs",
    "geometry_msgs",
    "nav_msgs",
    "rosgraph_msgs",
    "sensor_msgs",
    "std_msgs",
    "tf2_msgs",
)


@cache
def message_class(msgtype: str) -> type[Any]:
    """The class for ``msgtype`` (``pkg/msg/Name`` or ``pkg/Name``).

    Raises:
        KeyError: This package has no class for that type.
    """
    pkg, _, name = normalize_msgtype(msgtype).split("/")
    if pkg in PACKAGES:
        cls = getattr(importlib.import_module(f"racecar_sim.msgs.{pkg}"), name, None)
        if isinstance(cls, type) and getattr(cls, "__msgtype__", None) == f"{pkg}/msg/{name}":
            return cls
    raise KeyError(f"no message class for {msgtype!r}")


def msgtype_of(msg_or_cls: object) -> str:
    """The ROS 2 type name (``pkg/msg/Name``) of a message instance or class.

    Raises:
        TypeError: The object is not a message.
    """
    msgtype = getattr(msg_or_cls, "__msgtype__", None)
    if not isinstance(msgtype, str):
        raise TypeError(f"not a ROS message (no __msgtype__): {type(msg_or_cls).__name__}")
    return msgtype
