"""The ROS 1 bridge (`--ros`): the sim's topics, services, clock and parameters on a real ROS 1 master.

Debian's rospy runs under the system interpreter, maybe not the sim's, so the bridge is two processes: RosBridge
in the sim, and ros_side.py (a rospy node) under the interpreter that has rospy, talking over a pipe.
"""

from racecar_sim.bridges.ros1.bridge import DRAIN_RATE, RosBridge
from racecar_sim.bridges.ros1.environment import (
    INSTALL,
    RosUnavailable,
    message_path,
    ros_available,
    ros_python,
)
from racecar_sim.bridges.ros1.nodes import RosNodes

__all__ = ["DRAIN_RATE", "INSTALL", "RosBridge", "RosNodes", "RosUnavailable", "message_path", "ros_available", "ros_python"]
