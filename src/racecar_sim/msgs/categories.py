"""What kind of data a message type carries, read off its definition: the QoS category a ROS 2 bridge gives it.

A sensor's reading is a stamped ``sensor_msgs`` type (its first field a ``std_msgs/Header``): gazebo_ros's sensor
plugins publish every one of them with rclcpp's SensorDataQoS (best effort, keep last 5). Two stamped sensor_msgs
types are no sensor's reading: ``JointState`` (joint_state_publisher, ros2_control) and ``Joy`` (joy_node) go out
reliable, as any other topic. A new sensor_msgs definition (``Range``, ``NavSatFix``) is sensor data as it lands.
"""

from __future__ import annotations

from functools import cache

from racecar_sim.msgs.idl import available_msgtypes, get_spec, normalize_msgtype

SENSOR_PACKAGES = frozenset({"sensor_msgs"})
"""The packages whose stamped types are sensor readings."""

NOT_SENSOR_DATA = frozenset({"sensor_msgs/msg/JointState", "sensor_msgs/msg/Joy"})
"""Stamped sensor_msgs types that their publishers send reliably: a robot's state and a joystick's input."""


def is_sensor_data(msgtype: str) -> bool:
    """Whether ``msgtype`` (``pkg/msg/Name`` or ``pkg/Name``) is a sensor's reading (the ``sensor_data`` QoS).

    Raises:
        KeyError: No definition of that type is shipped.
    """
    msgtype = normalize_msgtype(msgtype)
    if msgtype.split("/", 1)[0] not in SENSOR_PACKAGES or msgtype in NOT_SENSOR_DATA:
        return False
    fields = get_spec(msgtype).fields
    return bool(fields) and fields[0].type == "std_msgs/msg/Header" and not fields[0].is_array


@cache
def sensor_data_types() -> frozenset[str]:
    """Every shipped message type that is a sensor's reading."""
    return frozenset(t for t in available_msgtypes() if is_sensor_data(t))
