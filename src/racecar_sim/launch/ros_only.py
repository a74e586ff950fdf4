"""A launch file with no car, run as roslaunch would run it: its parameters and nodes on a ROS 1 master.

The original `teleop.launch` and launch files like it start nodes for a sim that is already running; with
`racecar-sim launch FILE --ros` next to a `racecar-sim run --ros` (or `launch --ros`), their nodes join it. As
in roslaunch, a node that cannot start is one error line and the others go on; a `required` one ends the launch.
"""

from __future__ import annotations

import logging
import os

from racecar_sim.core.errors import ConfigError
from racecar_sim.launch.errors import LaunchError
from racecar_sim.launch.plan import LaunchPlan

log = logging.getLogger("racecar_sim.launch")


def has_car(plan: LaunchPlan) -> bool:
    """Whether the launch file spawns a car (gazebo_ros spawn_model), i.e. is a sim of its own."""
    return bool(plan.nodes_of("gazebo_ros", "spawn_model"))


class RosOnlyLaunch:
    """The nodes of a carless launch file as real ROS processes on `master_uri` (None: $ROS_MASTER_URI, else the
    master of a `run --ros` on 127.0.0.1:11311, else a roscore started here). Use as a context manager: leaving it
    stops the nodes (and a roscore it started)."""

    def __init__(self, plan: LaunchPlan, master_uri: str | None = None) -> None:
        from racecar_sim.bridges.ros1 import RosNodes  # only a --ros launch needs ROS 1
        from racecar_sim.bridges.ros1.master import DEFAULT_URI, master_up

        if master_uri is None and not os.environ.get("ROS_MASTER_URI") and master_up(DEFAULT_URI):
            master_uri = DEFAULT_URI
        self.plan = plan
        self.ros = RosNodes(master_uri)
        try:
            self.ros.set_params(plan.params)
            for node in plan.nodes:
                try:
                    self.ros.start_node(
                        node.package,
                        node.type,
                        node.name,
                        node.namespace,
                        node.args,
                        node.remaps,
                        dict(node.env) or None,
                    )
                except ConfigError as exc:  # no such package or node type
                    if node.required:
                        raise LaunchError(node.where, " ".join(str(exc).split())) from None
                    log.error("cannot launch node %s: %s", node.label, " ".join(str(exc).split()))
        except BaseException:
            self.ros.close()
            raise

    @property
    def running(self) -> int:
        """How many of the started nodes are still running."""
        return sum(p.poll() is None for p in self.ros.processes)

    def close(self) -> None:
        """Stop the nodes (SIGINT, as roslaunch) and a roscore started here."""
        self.ros.close()

    def __enter__(self) -> RosOnlyLaunch:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
