"""Reading numbers out of a Gazebo <sensor> block, with errors that name the sensor and the element."""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from typing import TYPE_CHECKING

from racecar_sim.core.errors import DescriptionError

if TYPE_CHECKING:
    from racecar_sim.description.urdf import Plugin

# a plugin block with a <ros> element or one of these parameters is in the ROS 2 dialect (sensors/ros2_dialect.py)
ROS2_PARAMS = ("frame_name", "output_type", "camera_name")


def is_ros2(plugin: Plugin) -> bool:
    """Whether a plugin block is written in the ROS 2 dialect (here, not in ros2_dialect: a description in ROS 1's
    does without that module's imports)."""
    return plugin.element.find("ros") is not None or any(p in plugin.params for p in ROS2_PARAMS)


def sensor_number(el: ET.Element, path: str, where: str, default: float | None = None, integer: bool = False) -> float:
    """The finite number at `path` under `el` (a whole one if `integer`); `default` when absent, else an error."""
    text = el.findtext(path)
    if text is None or not text.strip():
        if default is None:
            raise DescriptionError(f"{where}: <{el.tag}><{path}> is missing")
        return default
    try:
        value = float(text)
    except ValueError:
        raise DescriptionError(f"{where}: <{el.tag}><{path}> '{text.strip()}' is not a number") from None
    if not math.isfinite(value) or (integer and value != int(value)):
        kind = "a whole number" if integer else "a finite number"
        raise DescriptionError(f"{where}: <{el.tag}><{path}> '{text.strip()}' is not {kind}")
    return value


def plugin_number(params: dict[str, str], tag: str, where: str, default: float) -> float:
    """The finite number a gazebo_ros plugin parameter (<updateRateHZ>, <gaussianNoise>) holds; `default` when
    absent."""
    text = params.get(tag, "").strip()
    if not text:
        return default
    try:
        value = float(text)
    except ValueError:
        raise DescriptionError(f"{where}: <{tag}> '{text}' is not a number") from None
    if not math.isfinite(value):
        raise DescriptionError(f"{where}: <{tag}> '{text}' is not a finite number")
    return value


def join_topic(namespace: str, topic: str) -> str:
    """A gazebo_ros plugin's topic as its ros::NodeHandle(namespace) resolves it: an absolute topic as it is, a
    relative one under the namespace (``imu`` + ``data`` -> ``/imu/data``)."""
    if topic.startswith("/"):
        return topic
    return "/" + "/".join(part for part in (*namespace.split("/"), *topic.split("/")) if part)


def topic_and_frame(params: dict[str, str], default_topic: str) -> tuple[str, str]:
    """A ROS 1 gazebo_ros plugin's topic (<topicName> under <robotNamespace>) and frame (<frameName>, default /world,
    its leading slash dropped as tf::resolve drops it)."""
    topic = join_topic(params.get("robotNamespace", ""), params.get("topicName") or default_topic)
    return topic, (params.get("frameName") or "/world").lstrip("/")
