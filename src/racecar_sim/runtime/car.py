"""A car: one vehicle's description, controllers, driving profile, sensors, spawn pose and namespace.

`Car(...)` is what a user asks for; the Simulator builds it into the shared MuJoCo model (add_to) and then
starts its nodes on the shared bus (start): its own mux chain, servo_commands, controllers, joint states,
robot_state_publisher, odometry, lidar and camera, all named through its `CarNames`. `CarNodes` says which of
the original stack's nodes it runs (all of them by default; a launch file may leave some to ROS nodes).
"""

from __future__ import annotations

import logging
import weakref
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import mujoco

from racecar_sim.bus import Bus
from racecar_sim.control.commands import ControllerCommands
from racecar_sim.control.controller_manager import (
    JOINT_STATE_CONTROLLER,
    ControllerManager,
)
from racecar_sim.control.controllers import (
    ControllerConfig,
    add_actuators,
    load_controller_config,
)
from racecar_sim.control.mux import MUX_WIRING, CommandChain
from racecar_sim.control.profiles import Profile, load_profile
from racecar_sim.control.servo import ServoCommands
from racecar_sim.core.errors import ConfigError
from racecar_sim.core.names import ODOM_RELAY, CarNames
from racecar_sim.runtime.scheduler import Scheduler, Task, Timeout
from racecar_sim.description import (
    DEFAULT_XACRO,
    Robot,
    load_robot,
    package_path,
    parse_urdf,
)
from racecar_sim.physics import PhysicsPreset, add_car
from racecar_sim.physics.state import CarState
from racecar_sim.control.joint_state_controller import JointStatePublisher
from racecar_sim.sensors.odometry import FRAMES, OdometryPublisher
from racecar_sim.sensors.robot_state import RobotStatePublisher, StaticTransforms
from racecar_sim.worlds import Spawn

if TYPE_CHECKING:
    from racecar_sim.sensors.camera import CameraPublisher
    from racecar_sim.sensors.lidar import LidarPublisher

log = logging.getLogger("racecar_sim")
DEFAULT_CONTROLLERS = package_path("racecar_control") / "config" / "racecar_control.yaml"


@dataclass(frozen=True)
class CarNodes:
    """Which nodes of the original stack a car runs; the defaults are racecar.launch's full set. A launch file
    that leaves one out leaves its work to someone else (a user's own ROS node through the bridge).

    mux: the ackermann_cmd_mux chain's wiring (control/mux.py: a YAML path or the same as a mapping), None for
        no muxes, relays or default command. servo_input: servo_commands' input topic (car-relative), "" for the
        chain's output, None for no servo_commands. controllers: those the spawner loads and starts (None: every
        controller of the YAML; joint_state_controller included), stopped: those it only loads (--stopped).
    robot_state: robot_state_publisher, reading `joint_states` (car-relative; None: <controller ns>/joint_states).
    odometry: gazebo_odometry.py; odom_relay: the topic_tools relay of /vesc/odom (None: no relay).
    """

    mux: Path | Mapping[str, Any] | None = MUX_WIRING
    servo_input: str | None = ""
    controllers: tuple[str, ...] | None = None
    stopped: tuple[str, ...] = ()
    robot_state: bool = True
    joint_states: str | None = None
    odometry: bool = True
    odom_relay: str | None = ODOM_RELAY


class Car:
    """One RACECAR (or a user's own car) in a Simulator.

    name: its namespace ("" keeps the original names: /scan, base_link, Gazebo model `racecar`; "car2" gives
    /car2/scan, car2/base_link, model `car2`). spawn: its pose (the first car defaults to the world's).
    """

    def __init__(self, name: str = "", xacro: str | Path = DEFAULT_XACRO, xacro_args: Mapping[str, str] | None = None,
                 profile: str = "seed", controllers: str | Path | None = None, spawn: Spawn | None = None,
                 lidar: bool = True, camera: bool = True, odometry: str = "original",
                 nodes: CarNodes = CarNodes()) -> None:
        self.names = CarNames(name)
        self.name = name
        self.xacro = Path(xacro)
        self.xacro_args = dict(xacro_args or {})
        self.profile_name = profile
        self.controllers_file = Path(controllers or DEFAULT_CONTROLLERS)
        self.spawn = spawn
        self.want_lidar, self.want_camera = lidar, camera
        if odometry not in FRAMES:
            raise ConfigError(f"odometry mode {odometry!r} is not one of {', '.join(FRAMES)}")
        self.odometry_mode = odometry
        self.nodes = nodes
        self.chain: CommandChain | None = None
        self.servo: ServoCommands | None = None
        self.robot_state: RobotStatePublisher | None = None
        self.odometry: OdometryPublisher | None = None
        # set by the Simulator
        self.profile: Profile | None = None
        self.robot: Robot | None = None
        self.controllers: ControllerConfig | None = None
        self.state: CarState | None = None
        self.lidar: LidarPublisher | None = None
        self.camera: CameraPublisher | None = None
        self.urdf: str | None = None  # an expanded URDF to use instead of the xacro (spawn_urdf_model)
        self._bus: _CarBus | None = None
        self._scheduler: _CarScheduler | None = None

    def __repr__(self) -> str:
        return f"Car({self.name or 'racecar'!r})"

    @property
    def model_name(self) -> str:
        """Its Gazebo model name (`racecar` for the unnamed car, else its namespace)."""
        return self.names.model

    def load(self, twin: Car | None = None) -> None:
        """Read the profile, expand the xacro and check the controllers against it; or, when `twin` (loaded already)
        asked for the same description, profile and controllers, share what it read (a fleet of N identical cars
        expands the xacro once: ~0.1 s a car otherwise; the parsed description and configuration are immutable)."""
        if twin is not None and twin.robot is not None and self._load_key() == twin._load_key():
            self.profile, self.robot, self.controllers = twin.profile, twin.robot, twin.controllers
            self.has_lidar = self.want_lidar and self.robot.sensor("ray") is not None
            self.has_camera = self.want_camera and self.robot.sensor("camera") is not None
            return
        self.profile = load_profile(self.profile_name)
        if self.urdf is not None:  # already expanded: the profile's xacro arguments cannot apply any more
            self.robot = parse_urdf(self.urdf, source=f"the URDF of {self.model_name}")
        else:
            self.robot = load_robot(self.xacro, {**self.profile.xacro_args, **self.xacro_args})
        self.controllers = load_controller_config(self.controllers_file, self.robot)
        self.has_lidar = self.want_lidar and self.robot.sensor("ray") is not None
        self.has_camera = self.want_camera and self.robot.sensor("camera") is not None

    def _load_key(self) -> tuple:
        return (self.profile_name, self.xacro, tuple(sorted(self.xacro_args.items())), self.controllers_file,
                self.urdf)

    def add_to(self, spec: mujoco.MjSpec, preset: PhysicsPreset, spawn: Spawn, rank_friction: bool = True) -> None:
        """Put the car into the scene's MjSpec at `spawn`, with its actuators (and its camera); rank_friction=False
        leaves builder.friction_min_rule to the caller (once, after the last car of a fleet)."""
        add_car(spec, self.robot, spawn, preset, self.names, rank_friction)
        add_actuators(spec, self.controllers, self.robot, self.names)
        if self.has_camera:
            from racecar_sim.sensors.camera import (
                add_camera,  # GL bindings load only when a camera is wanted
            )

            add_camera(spec, self.robot, self.names)

    def start(self, model: mujoco.MjModel, data: mujoco.MjData, bus: Bus, scheduler: Scheduler,
              now: Callable[[], int], static_tf: StaticTransforms, seed: int, noise: bool) -> None:
        """Start the car's nodes of the original stack on the bus. Called once: they live as long as the Simulator
        (or until stop(): the car was deleted). Their timers start now (a car spawned at t = 2 s scans at 2.025 s...,
        as a Gazebo sensor counts from its load), and everything they hold on the bus is kept for stop()."""
        self._bus, self._scheduler = bus, scheduler = _CarBus(bus), _CarScheduler(scheduler, now())
        names, robot, controllers, profile = self.names, self.robot, self.controllers, self.profile
        self.state = CarState(model, data, robot.root, names)
        self.commands = ControllerCommands(bus, self.state, controllers, robot, now, names)
        nodes = self.nodes
        if nodes.mux is not None:
            self.chain = CommandChain(bus, scheduler, now, nodes.mux, names=names)
        if nodes.servo_input is not None:
            servo_input = names.topic(nodes.servo_input) if nodes.servo_input else self._chain_output()
            self.servo = ServoCommands(bus, robot, controllers, profile.servo, servo_input,
                                       profile.wheel_rate_per_speed, now, names)
        joints = [c.joint for c in controllers.controllers]
        joint_states = names.topic(f"{controllers.namespace}/joint_states")
        self.joint_states = JointStatePublisher(bus, scheduler, self.state, joints, controllers.joint_state_rate,
                                                joint_states)
        self.controller_manager = ControllerManager(bus, scheduler, self.state, controllers, robot, self.joint_states,
                                                    names)
        self._spawn_controllers()
        if nodes.robot_state:
            rsp_input = names.topic(nodes.joint_states) if nodes.joint_states else joint_states
            self.robot_state = RobotStatePublisher(bus, robot, rsp_input, names, static_tf)
        if nodes.odometry:
            self.odometry = OdometryPublisher(bus, scheduler, self.state, self.odometry_mode,
                                              relay_topic=nodes.odom_relay, names=names)
        if self.has_lidar:
            from racecar_sim.sensors.lidar import LidarPublisher

            self.lidar = LidarPublisher(bus, scheduler, model, data, robot, seed, noise=noise, names=names)
        if self.has_camera:
            from racecar_sim.sensors.camera import CameraPublisher, RenderingError

            try:
                self.camera = CameraPublisher(bus, scheduler, model, data, robot, seed, noise=noise, names=names)
            except RenderingError as exc:
                log.error("%s; continuing without the camera", exc)
                self.has_camera, self.camera = False, None

    def _chain_output(self) -> str:
        if self.chain is None:
            raise ConfigError(f"{self.model_name}: servo_commands reads the mux chain's output, but the car has no "
                              "mux chain: give CarNodes(servo_input=TOPIC)")
        return self.chain.output_topic

    def _spawn_controllers(self) -> None:
        """What the spawner leaves: the controllers it names loaded (and started unless --stopped), no others."""
        wanted, stopped = self.nodes.controllers, set(self.nodes.stopped)
        if wanted is None and not stopped:
            return
        defined = [c.name for c in self.controllers.controllers] + [JOINT_STATE_CONTROLLER]
        keep = stopped | set(defined if wanted is None else wanted)
        unknown = sorted(keep - set(defined))
        if unknown:
            raise ConfigError(f"{self.model_name}: controller {', '.join(unknown)} is not in the controller parameters "
                              f"(namespace {self.controllers.namespace}): load its parameters (rosparam) or drop it")
        manager = self.controller_manager
        manager.switch_controller([], [c for c in defined if c not in keep or c in stopped])
        for name in [c for c in defined if c not in keep]:
            manager.unload_controller(name)

    def reset(self, seed: int) -> None:
        """Back to a fresh start: muxes idle, no held command, sensors' noise from `seed`."""
        if self.chain is not None:
            self.chain.reset()
        self.controller_manager.reset()  # every controller of the YAML loaded and running, as the spawner leaves them
        self._spawn_controllers()
        for sensor in (self.lidar, self.camera):
            if sensor is not None:
                sensor.seed = seed
        if self.camera is not None:
            self.camera.drop_pending()  # a frame drawn ahead of the reset shows the old episode

    def close(self) -> None:
        """Free the camera's GL context."""
        if self.camera is not None:
            self.camera.close()
            self.camera = None

    def rebind(self, model: mujoco.MjModel, data: mujoco.MjData) -> None:
        """Go on in a recompiled model (a model was spawned or deleted): the same nodes, new ids and addresses."""
        self.state.rebind(model, data)
        if self.lidar is not None:
            self.lidar.rebind(model, data)
        if self.camera is not None:
            self.camera.rebind(model, data)

    def stop(self) -> None:
        """Take the car's nodes off the bus (delete_model): cancel their timers, drop their subscriptions and
        services, close the sensors."""
        if self._scheduler is not None:
            self._scheduler.cancel_all()
        if self._bus is not None:
            self._bus.release()
        if self.lidar is not None:
            self.lidar.close()
        self.close()

    def remove_from(self, spec: mujoco.MjSpec) -> None:
        """Delete the car from the scene's MjSpec: its bodies (with their geoms, joints, sites and camera), the
        actuators on its joints and its contact exclusions."""
        root = spec.body(self.names.mj(self.robot.root))
        if root is None:
            return
        bodies = {root.name} | {b.name for b in root.find_all(mujoco.mjtObj.mjOBJ_BODY)}
        joints = {j.name for j in root.find_all(mujoco.mjtObj.mjOBJ_JOINT)}
        for actuator in [a for a in spec.actuators if a.target in joints]:
            spec.delete(actuator)
        for exclude in [e for e in spec.excludes if e.bodyname1 in bodies or e.bodyname2 in bodies]:
            spec.delete(exclude)
        spec.delete(root)

    def topic(self, name: str) -> str:
        """One of this car's topics by its original name: car.topic("/scan") -> "/car2/scan"."""
        return self.names.topic(name)


class _CarBus:
    """The shared bus as one car's nodes see it: everything passes through, and the subscriptions and services
    they make are remembered so that release() can take them away again."""

    def __init__(self, bus: Bus) -> None:
        self._bus = bus
        self.publish = bus.publish  # the hot paths, without a __getattr__ per call
        self.has_listeners = bus.has_listeners
        self.tally = bus.tally
        self._subscriptions: list[Any] = []
        self._services: list[str] = []

    def subscribe(self, topic: str, callback: Callable[[Any], None], msgtype: type | None = None,
                  feeds: Mapping[str, type] | None = None) -> Any:
        sub = self._bus.subscribe(topic, callback, msgtype, feeds)
        self._subscriptions.append(sub)
        return sub

    def advertise_service(self, name: str, handler: Callable[[Any], Any]) -> None:
        self._bus.advertise_service(name, handler)
        self._services.append(name)

    def release(self) -> None:
        for sub in self._subscriptions:
            sub.unsubscribe()
        for name in self._services:
            self._bus.unadvertise_service(name)
        self._subscriptions, self._services = [], []

    def __getattr__(self, name: str) -> Any:
        return getattr(self._bus, name)


class _CarScheduler:
    """The shared scheduler as one car's nodes see it: periodic tasks count from the car's start time, and every
    live task is remembered (weakly: fired one-shot timers are forgotten) so that cancel_all() can stop them."""

    def __init__(self, scheduler: Scheduler, start_ns: int) -> None:
        self._scheduler, self._start_ns = scheduler, start_ns
        self._tasks: weakref.WeakSet[Task] = weakref.WeakSet()

    def every(self, rate_hz: float, callback: Callable[[int], None], name: str, start_ns: int = 0,
              unheard: Callable[[int], bool] | None = None) -> Task:
        task = self._scheduler.every(rate_hz, callback, name, max(start_ns, self._start_ns), unheard)
        self._tasks.add(task)
        return task

    def at(self, time_ns: int, callback: Callable[[int], None], name: str) -> Task:
        task = self._scheduler.at(time_ns, callback, name)
        self._tasks.add(task)
        return task

    def timeout(self, callback: Callable[[int], None], name: str) -> Timeout:
        task = self._scheduler.timeout(callback, name)
        self._tasks.add(task)
        return task

    def cancel_all(self) -> None:
        for task in list(self._tasks):
            task.cancel()

    def __getattr__(self, name: str) -> Any:
        return getattr(self._scheduler, name)
