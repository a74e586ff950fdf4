"""`racecar-sim ros-env`: the shell lines that let a user's own ROS 1 nodes talk to `racecar-sim run --ros`.

`eval "$(racecar-sim ros-env)"` puts the message packages Debian does not ship (ackermann_msgs, gazebo_msgs,
control_msgs, controller_manager_msgs; generated with genpy on first use) on PYTHONPATH, and points ROS_MASTER_URI
at the master `run --ros` uses: $ROS_MASTER_URI, else the roscore it starts on http://127.0.0.1:11311/.

Time: with --ros the sim sets /use_sim_time and publishes /clock, so sim-time nodes follow the sim, and it keeps to
the wall clock, as Gazebo does (`run --ros` goes on until Ctrl-C unless --duration is given). With --fast it runs as
fast as it can: a node slower than that sees sim time jump between its callbacks, and what it cannot take in time is
dropped by its subscriber's queue_size (rospy keeps the newest), never slowing the sim down; the sim waits for nobody
but the pipe to the bridge, and messages reach ROS in batches of up to a few milliseconds of wall time.
"""

from __future__ import annotations

import argparse
import os
import shlex
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from racecar_sim.bridges.ros1 import RosBridge
    from racecar_sim.runtime import Simulator

# The module also holds the --ros options that run and launch share, and starting the bridge for them. The bridge's
# modules (xmlrpc, http.client, hashlib: ~20 ms) are imported only by a run that asks for ROS.
PAUSED_WAIT = 0.01  # s the run loop waits for ROS calls (unpause_physics) while the physics is paused
LOOPBACK = "127.0.0.1"  # bridges/ros1/environment.py's, for the help texts (a test holds them equal)
DEFAULT_PORT = 11311  # bridges/ros1/master.py's: the ROS master's port


def add_parser(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser(
        "ros-env",
        help='shell lines for your own ROS 1 nodes: eval "$(racecar-sim ros-env)"',
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument(
        "--ros-master",
        metavar="URI",
        help=f"the master to print (default $ROS_MASTER_URI, else http://{LOOPBACK}:{DEFAULT_PORT}/)",
    )


def add_ros_arguments(parser: argparse.ArgumentParser, help: str | None = None) -> None:
    """--ros and --ros-master (`help`: --ros's own, where a command does more with it)."""
    parser.add_argument(
        "--ros",
        action="store_true",
        help=help
        or "bridge to ROS 1: every topic published with its ROS 1 type, command topics and the "
        "Gazebo / controller manager services offered, /clock and /use_sim_time set (needs "
        "Debian's ROS 1 packages; see `racecar-sim ros-env --help`)",
    )
    parser.add_argument(
        "--ros-master",
        metavar="URI",
        help="with --ros: the ROS master (default $ROS_MASTER_URI, else a roscore started on "
        f"127.0.0.1:{DEFAULT_PORT} or a free port)",
    )


def check_ros(args: argparse.Namespace) -> None:
    """RosUnavailable (one line, exit code 2) before anything is built, when --ros is asked for without ROS."""
    if getattr(args, "ros", False):
        from racecar_sim.bridges.ros1.environment import ros_python

        ros_python()


def start_ros_bridge(args: argparse.Namespace, sim: Simulator) -> RosBridge | None:
    """The started bridge when --ros is given, else None."""
    if not getattr(args, "ros", False):
        return None
    import sys

    from racecar_sim.bridges.ros1 import RosBridge
    from racecar_sim.cli.topic_map import topic_map_of

    bridge = RosBridge(sim, args.ros_master, topic_map=topic_map_of(args, sim))
    bridge.start()
    print(
        f'racecar-sim: ROS 1 bridge on {bridge.master_uri} (for your nodes: eval "$(racecar-sim ros-env '
        f'--ros-master {bridge.master_uri})")',
        file=sys.stderr,
    )
    return bridge


def main(args: argparse.Namespace) -> int:
    from racecar_sim.bridges.ros1.environment import message_path, ros_python

    python = ros_python()
    master = args.ros_master or os.environ.get("ROS_MASTER_URI") or f"http://{LOOPBACK}:{DEFAULT_PORT}/"
    messages = message_path(python)
    print(f"export PYTHONPATH={shlex.quote(str(messages))}${{PYTHONPATH:+:$PYTHONPATH}}")
    print(f"export ROS_MASTER_URI={shlex.quote(master)}")
    if not os.environ.get("ROS_IP") and not os.environ.get("ROS_HOSTNAME"):
        print(f"export ROS_IP={LOOPBACK}")
    return 0
