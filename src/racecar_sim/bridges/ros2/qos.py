"""The QoS of each bridged topic: chosen so that every subscriber and publisher a ROS 2 user writes matches.

DDS matches a publisher and a subscription only when the publisher offers at least what the subscription asks: a
RELIABLE publisher serves RELIABLE and BEST_EFFORT subscriptions, a BEST_EFFORT one only BEST_EFFORT ones; a
TRANSIENT_LOCAL publisher serves TRANSIENT_LOCAL and VOLATILE subscriptions. User code subscribes with a plain depth
(`create_subscription(LaserScan, '/scan', cb, 10)`: RELIABLE, VOLATILE, as the F1TENTH labs and f1tenth_gym_ros write
it) or with `qos_profile_sensor_data` (BEST_EFFORT), and latched topics with TRANSIENT_LOCAL. So:

  out (the sim publishes)  always RELIABLE; latched topics TRANSIENT_LOCAL (keep last 1: a late subscriber gets it)
      sensor data          /scan, camera images, point clouds, IMU, range, GPS (msgs/categories.py): keep last 5
      /tf                  keep last 100 (tf2_ros's TransformBroadcaster)
      /clock               keep last 1 (its readers keep the newest)
      default              keep last 10
      a topic map's own    what the stack it imitates publishes with (f1tenth_gym_ros: keep last 10)
  in (the sim subscribes)  BEST_EFFORT, VOLATILE, keep last 10: takes publishers of either reliability and durability

Configuration as data: a profile per kind of topic, chosen by the topic's name, then latching, then its message type.
"""

from __future__ import annotations

from typing import Any

from racecar_sim.msgs.categories import is_sensor_data

PROFILES: dict[str, dict[str, Any]] = {
    "sensor_data": {"reliability": "reliable", "durability": "volatile", "depth": 5},
    "tf": {"reliability": "reliable", "durability": "volatile", "depth": 100},
    "tf_static": {"reliability": "reliable", "durability": "transient_local", "depth": 1},
    "clock": {"reliability": "reliable", "durability": "volatile", "depth": 1},
    "latched": {"reliability": "reliable", "durability": "transient_local", "depth": 1},
    "default": {"reliability": "reliable", "durability": "volatile", "depth": 10},
    "command": {"reliability": "best_effort", "durability": "volatile", "depth": 10},
}
BY_TOPIC = {"/tf": "tf", "/tf_static": "tf_static", "/clock": "clock"}


def profile_name(topic: str, msgtype: str, latched: bool = False, named: str | None = None) -> str:
    """The name of the profile the sim publishes `topic` (its name on ROS) with, carrying `msgtype` (`pkg/msg/Name`).
    `named`: the profile a topic map gives the topic (None: the sim's own choice)."""
    if topic in BY_TOPIC:
        return BY_TOPIC[topic]
    if latched:
        return "latched"
    if named is not None:
        return named
    return "sensor_data" if _is_sensor_data(msgtype) else "default"


def profile(topic: str, msgtype: str, latched: bool = False, named: str | None = None) -> dict[str, Any]:
    """The profile the sim publishes `topic` with: reliability ("reliable" | "best_effort"), durability ("volatile" |
    "transient_local") and depth (keep last)."""
    return dict(PROFILES[profile_name(topic, msgtype, latched, named)])


def _is_sensor_data(msgtype: str) -> bool:
    """A sensor's reading (msgs/categories.py: a stamped sensor_msgs type, read off its definition)."""
    try:
        return is_sensor_data(msgtype)
    except KeyError:  # a type with no shipped definition: not a sensor of ours
        return False


def command_profile() -> dict[str, Any]:
    """The profile of the sim's subscriptions to the topics it takes commands on (any publisher matches it)."""
    return dict(PROFILES["command"])
