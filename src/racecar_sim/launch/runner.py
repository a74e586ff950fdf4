"""A SimSetup running: the Simulator, the launch's drivers, relays and keyboard inputs, and with `ros` the ROS 1
bridge with the parameter tree and the nodes the sim has no equivalent for."""

from __future__ import annotations

import logging
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from racecar_sim.control.teleop import KeyboardTeleop
from racecar_sim.core.errors import ConfigError
from racecar_sim.description.vehicle import VehicleGeometry
from racecar_sim.drivers import (
    ConstantCommand,
    PurePursuit,
    WallFollower,
    load_waypoints,
    pure_pursuit_config,
    wall_follow_config,
)
from racecar_sim.launch.errors import LaunchError
from racecar_sim.launch.mapping import DriverSpec, SimSetup
from racecar_sim.runtime import Simulator

log = logging.getLogger("racecar_sim.launch")
CONSTANT_DEFAULTS = {"speed": 1.0, "steering": 0.0, "rate": 20.0}


class LaunchRun:
    """The sim a launch file describes. Use as a context manager (close() stops the bridge and its nodes)."""

    def __init__(self, setup: SimSetup, seed: int = 0, physics: str = "default", sensor_noise: bool = True,
                 model_path: Sequence[str | Path] = (), ros: bool = False, master_uri: str | None = None) -> None:
        self.setup = setup
        self.sim = Simulator(world=setup.world.world, cars=setup.cars, seed=seed, physics=physics,
                             model_path=list(model_path), sensor_noise=sensor_noise)
        self.bridge: Any = None
        try:
            self.sim.paused = setup.world.paused  # gazebo -u: sim time waits for /gazebo/unpause_physics
            self.drivers = [self._driver(spec) for spec in setup.drivers]
            for source, target in setup.relays:
                self.sim.subscribe(source, lambda msg, target=target: self.sim.bus.publish(target, msg))
            self.teleops = [KeyboardTeleop(self.sim.bus, self.sim.scheduler, lambda: self.sim.time_ns, topic=topic)
                            for topic in setup.teleop_topics]
            if ros:
                self._start_ros(master_uri)
        except BaseException:
            self.close()
            raise

    def _driver(self, spec: DriverSpec) -> object:
        sim, params = self.sim, dict(spec.params)
        try:
            if spec.kind == "wall_follow":
                return WallFollower(sim.bus, wall_follow_config(**params), spec.topic, spec.scan_topic, spec.odom_topic)
            if spec.kind == "pure_pursuit":
                path = params.pop("path", None)
                if not path:
                    raise LaunchError(spec.node.where, "pure_pursuit needs a path param (a waypoint CSV)",
                                      "add <param name=\"path\" value=\"FILE.csv\"/> to the node")
                wheelbase = VehicleGeometry.from_robot(sim.car_named(spec.car).robot).wheelbase
                config = pure_pursuit_config(**{"wheelbase": wheelbase, **params})
                return PurePursuit(sim.bus, load_waypoints(path), config, spec.topic, spec.odom_topic)
            unknown = sorted(set(params) - set(CONSTANT_DEFAULTS))
            if unknown:
                raise LaunchError(spec.node.where, f"constant has no param {unknown[0]!r}",
                                  f"use {', '.join(CONSTANT_DEFAULTS)}")
            options = {**CONSTANT_DEFAULTS, **params}
            return ConstantCommand(sim.bus, sim.scheduler, float(options["speed"]), float(options["steering"]),
                                   float(options["rate"]), spec.topic)
        except LaunchError:
            raise
        except (ConfigError, TypeError, ValueError) as exc:
            raise LaunchError(spec.node.where, f"{spec.kind}: {' '.join(str(exc).split())}",
                              "fix the node's private params") from None

    def _start_ros(self, master_uri: str | None) -> None:
        from racecar_sim.bridges.ros1 import RosBridge  # only a --ros run needs ROS 1

        self.bridge = RosBridge(self.sim, master_uri)
        self.bridge.start()
        self.bridge.set_params(self.setup.plan.params)
        for node in self.setup.ros_nodes:
            log.info("starting ROS node %s", node.label)
            try:
                self.bridge.start_node(node.package, node.type, node.name, node.namespace, node.args, node.remaps,
                                       dict(node.env) or None)
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
