"""ROS 2-shaped message classes, their ``.msg`` definitions and CDR serialization.

Field names follow ROS 2 exactly (``msg.header.stamp.sec``, ``scan.ranges``,
``cmd.drive.steering_angle``), numeric arrays are numpy arrays, and
``serialize``/``deserialize`` produce and read the bytes rosbag2 stores. A message type is its ``.msg`` file in
msgs/definitions: its class is made from it (msgs/generate.py) and is exported here by its bare name and from its
package's module (``racecar_sim.msgs.sensor_msgs.LaserScan``).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from racecar_sim.msgs import (
    ackermann_msgs,
    builtin_interfaces,
    control_msgs,
    controller_manager_msgs,
    gazebo_msgs,
    geometry_msgs,
    nav_msgs,
    rosgraph_msgs,
    sensor_msgs,
    std_msgs,
    tf2_msgs,
)
from racecar_sim.msgs.cdr import deserialize, serialize
from racecar_sim.msgs.generate import message_type
from racecar_sim.msgs.idl import available_msgtypes, schema_text
from racecar_sim.msgs.registry import message_class, msgtype_of

if TYPE_CHECKING:
    from racecar_sim.msgs.typed import *  # noqa: F403  # every message class's type


def _by_name() -> dict[str, list[str]]:
    names: dict[str, list[str]] = {}
    for msgtype in available_msgtypes():
        names.setdefault(msgtype.rsplit("/", 1)[1], []).append(msgtype)
    return names


def __getattr__(name: str) -> Any:
    """Every message type by its bare name (``msgs.LaserScan``), when one package alone defines it."""
    found = _by_name().get(name, [])
    if len(found) != 1:
        more = f": defined by {', '.join(found)}; import it from its package's module" if found else ""
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}{more}")
    cls = message_type(found[0])
    globals()[name] = cls
    return cls


__all__ = [
    *sorted(name for name, types in _by_name().items() if len(types) == 1),
    "ackermann_msgs",
    "builtin_interfaces",
    "control_msgs",
    "controller_manager_msgs",
    "deserialize",
    "gazebo_msgs",
    "geometry_msgs",
    "message_class",
    "msgtype_of",
    "nav_msgs",
    "rosgraph_msgs",
    "schema_text",
    "sensor_msgs",
    "serialize",
    "std_msgs",
    "tf2_msgs",
]
