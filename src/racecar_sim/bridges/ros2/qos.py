"""The QoS of each bridged topic, as a ROS 2 user expects it from the Gazebo plugins, tf2 and ros2_control.

Configuration as data: a profile per kind of topic, chosen by the topic's name and then its message type.
  sensor data   /scan, camera images and infos, point clouds, IMU: best effort, keep last 5 (rclpy's
                qos_profile_sensor_data, what gazebo_ros's sensor plugins publish with)
  /tf           reliable, volatile, keep last 100 (tf2_ros's TransformBroadcaster and listener)
  /tf_static    reliable, transient local, keep last 1 (tf2_ros's static broadcaster: a late subscriber gets it)
  /clock        best effort, keep last 1 (rclcpp::ClockQoS, what gazebo_ros publishes it with and what a node with
                use_sim_time subscribes with)
  latched       any other topic the sim latches: reliable, transient local, keep last 1
  default       everything else, commands taken from ROS included: reliable, volatile, keep last 10
"""

from __future__ import annotations

from typing import Any

PROFILES: dict[str, dict[str, Any]] = {
    "sensor_data": {"reliability": "best_effort", "durability": "volatile", "depth": 5},
    "tf": {"reliability": "reliable", "durability": "volatile", "depth": 100},
    "tf_static": {"reliability": "reliable", "durability": "transient_local", "depth": 1},
    "clock": {"reliability": "best_effort", "durability": "volatile", "depth": 1},
    "latched": {"reliability": "reliable", "durability": "transient_local", "depth": 1},
    "default": {"reliability": "reliable", "durability": "volatile", "depth": 10},
}
BY_TOPIC = {"/tf": "tf", "/tf_static": "tf_static", "/clock": "clock"}
SENSOR_TYPES = frozenset(
    {
        "sensor_msgs/msg/LaserScan",
        "sensor_msgs/msg/Image",
        "sensor_msgs/msg/CompressedImage",
        "sensor_msgs/msg/CameraInfo",
        "sensor_msgs/msg/PointCloud2",
        "sensor_msgs/msg/Imu",
    }
)


def profile_name(topic: str, msgtype: str, latched: bool = False) -> str:
    """The name of the profile of `topic` (its name on ROS) carrying `msgtype` (`pkg/msg/Name`)."""
    if topic in BY_TOPIC:
        return BY_TOPIC[topic]
    if latched:
        return "latched"
    return "sensor_data" if msgtype in SENSOR_TYPES else "default"


def profile(topic: str, msgtype: str, latched: bool = False) -> dict[str, Any]:
    """The profile of `topic`: reliability ("reliable" | "best_effort"), durability ("volatile" |
    "transient_local") and depth (keep last)."""
    return dict(PROFILES[profile_name(topic, msgtype, latched)])
