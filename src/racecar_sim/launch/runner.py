"""A SimSetup running: the Simulator, the launch's drivers, relays and keyboard inputs, and with `ros` the ROS 1
bridge with the parameter tree and the nodes the sim has no equivalent for."""

from __future__ import annotations

import logging
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

from racecar_sim.control.teleop import KeyboardTeleop
from racecar_sim.core.errors import ConfigError
from racecar_sim.launch.errors import LaunchError
from racecar_sim.launch.mapping import DriverSpec, SimSetup
from racecar_sim.runtime import Simulator
from racecar_sim.runtime.driving import attach_driver

if TYPE_CHECKING:
    from racecar_sim.bridges.ros1 import RosBridge

log = logging.getLogger("racecar_sim.launch")
# a launch file's driver node types and the run command's driver names
DRIVER_NAMES = {"wall_follow": "wall-follow", "pure_pursuit": "pure-pursuit", "constant": "constant"}


class LaunchRun:
    """The sim a launch file describes. Use as a context manager (close() stops the bridge and its nodes)."""

    def __init__(
        self,
        setup: SimSetup,
        seed: int = 0,
        physics: str = "default",
        sensor_noise: bool = True,
        model_path: Sequence[str | Path] = (),
        ros: bool = False,
        master_uri: str | None = None,
        topic_map: str | None = None,
        start_line: Sequence[float] | None = None,
    ) -> None:
        self.setup = setup
        self.topic_map_name = topic_map  # the names on ROS (bridges/topic_map.py; None: the sim's)
        self.sim = Simulator(
            world=setup.world.world,
            cars=setup.cars,
            seed=seed,
            physics=physics,
            model_path=list(model_path),
            sensor_noise=sensor_noise,
            start_line=start_line,
        )
        self.bridge: RosBridge | None = None
        try:
            self.sim.paused = setup.world.paused  # gazebo -u: sim time waits for /gazebo/unpause_physics
            self.drivers = [self._driver(spec) for spec in setup.drivers]
            for source, target in setup.relays:

                def relay(msg: Any, target: str = target) -> None:
                    self.sim.bus.publish(target, msg)

                self.sim.subscribe(source, relay)
            self.teleops = [
                KeyboardTeleop(self.sim.bus, self.sim.scheduler, lambda: self.sim.time_ns, topic=topic)
                for topic in setup.teleop_topics
            ]
            self.joy_teleops = [spec.start(self.sim) for spec in setup.joy_teleops]
            self.joy_nodes = [node for spec in setup.joy_nodes if (node := spec.start(self.sim, ros)) is not None]
            if ros:
                self._start_ros(master_uri)
        except BaseException:
            self.close()
            raise

    def _driver(self, spec: DriverSpec) -> object:
        try:
            return attach_driver(
                self.sim,
                self.sim.car_named(spec.car),
                DRIVER_NAMES[spec.kind],
                spec.params,
                spec.topic,
                spec.scan_topic,
                spec.odom_topic,
            )
        except (ConfigError, TypeError, ValueError) as exc:
            raise LaunchError(
                spec.node.where, f"{spec.kind}: {' '.join(str(exc).split())}", "fix the node's private params"
            ) from None

    def _start_ros(self, master_uri: str | None) -> None:
        from racecar_sim.bridges.ros1 import RosBridge  # only a --ros run needs ROS 1
        from racecar_sim.bridges.topic_map import make_topic_map

        self.bridge = RosBridge(
            self.sim, master_uri, topic_map=make_topic_map(self.topic_map_name or "identity", self.sim)
        )
        self.bridge.start()
        self.bridge.set_params(self.setup.plan.params)
        for node in self.setup.ros_nodes:
            log.info("starting ROS node %s", node.label)
            try:
                self.bridge.start_node(
                    node.package, node.type, node.name, node.namespace, node.args, node.remaps, dict(node.env) or None
                )
            except ConfigError as exc:  # no such package or node type
                raise LaunchError(node.where, " ".join(str(exc).split())) from None

    def close(self) -> None:
        """Stop the bridge (and the ROS nodes it started), finish recordings, free the cameras."""
        if self.bridge is not None:
            self.bridge.close()
            self.bridge = None
        self.sim.close()

    def __enter__(self) -> LaunchRun:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
