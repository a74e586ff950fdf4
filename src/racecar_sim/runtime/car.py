"""A car: one vehicle's description, controllers, driving profile, sensors, spawn pose and namespace.

`Car(...)` is what a user asks for; the Simulator builds it into the shared MuJoCo model (add_to) and then
starts its nodes on the shared bus (start): its own mux chain, servo_commands, controllers, joint states,
robot_state_publisher, odometry, lidar and camera, all named through its `CarNames`.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import TYPE_CHECKING

import mujoco

from racecar_sim.bus import Bus
from racecar_sim.control.commands import ControllerCommands
from racecar_sim.control.controllers import ControllerConfig, add_actuators, load_controller_config
from racecar_sim.control.mux import CommandChain
from racecar_sim.control.profiles import Profile, load_profile
from racecar_sim.control.servo import ServoCommands
from racecar_sim.core.errors import ConfigError
from racecar_sim.core.names import CarNames
from racecar_sim.core.scheduler import Scheduler
from racecar_sim.description import DEFAULT_XACRO, Robot, load_robot, package_path
from racecar_sim.physics import PhysicsPreset, add_car
from racecar_sim.physics.state import CarState
from racecar_sim.sensors.joint_states import JointStatePublisher
from racecar_sim.sensors.odometry import FRAMES, OdometryPublisher
from racecar_sim.sensors.robot_state import RobotStatePublisher, StaticTransforms
from racecar_sim.worlds import Spawn

if TYPE_CHECKING:
    from racecar_sim.sensors.camera import CameraPublisher
    from racecar_sim.sensors.lidar import LidarPublisher

log = logging.getLogger("racecar_sim")
DEFAULT_CONTROLLERS = package_path("racecar_control") / "config" / "racecar_control.yaml"


class Car:
    """One RACECAR (or a user's own car) in a Simulator.

    name: its namespace ("" keeps the original names: /scan, base_link, Gazebo model `racecar`; "car2" gives
    /car2/scan, car2/base_link, model `car2`). spawn: its pose (the first car defaults to the world's).
    """

    def __init__(self, name: str = "", xacro: str | Path = DEFAULT_XACRO, xacro_args: Mapping[str, str] | None = None,
                 profile: str = "seed", controllers: str | Path | None = None, spawn: Spawn | None = None,
                 lidar: bool = True, camera: bool = True, odometry: str = "original") -> None:
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
        # set by the Simulator
        self.profile: Profile | None = None
        self.robot: Robot | None = None
        self.controllers: ControllerConfig | None = None
        self.state: CarState | None = None
        self.lidar: LidarPublisher | None = None
        self.camera: CameraPublisher | None = None

    def __repr__(self) -> str:
        return f"Car({self.name or 'racecar'!r})"

    @property
    def model_name(self) -> str:
        """Its Gazebo model name (`racecar` for the unnamed car, else its namespace)."""
        return self.names.model

    def load(self) -> None:
        """Read the profile, expand the xacro and check the controllers against it."""
        self.profile = load_profile(self.profile_name)
        self.robot = load_robot(self.xacro, {**self.profile.xacro_args, **self.xacro_args})
        self.controllers = load_controller_config(self.controllers_file, self.robot)
        self.has_lidar = self.want_lidar and self.robot.sensor("ray") is not None
        self.has_camera = self.want_camera and self.robot.sensor("camera") is not None

    def add_to(self, spec: mujoco.MjSpec, preset: PhysicsPreset, spawn: Spawn) -> None:
        """Put the car into the scene's MjSpec at `spawn`, with its actuators (and its camera)."""
        add_car(spec, self.robot, spawn, preset, self.names)
        add_actuators(spec, self.controllers, self.robot, self.names)
        if self.has_camera:
            from racecar_sim.sensors.camera import add_camera  # GL bindings load only when a camera is wanted

            add_camera(spec, self.robot, self.names)

    def start(self, model: mujoco.MjModel, data: mujoco.MjData, bus: Bus, scheduler: Scheduler,
              now: Callable[[], int], static_tf: StaticTransforms, seed: int, noise: bool) -> None:
        """Start the car's nodes of the original stack on the bus. Called once: they live as long as the Simulator."""
        names, robot, controllers, profile = self.names, self.robot, self.controllers, self.profile
        self.state = CarState(model, data, robot.root, names)
        self.commands = ControllerCommands(bus, self.state, controllers, robot, now, names)
        self.chain = CommandChain(bus, scheduler, now, names=names)
        self.servo = ServoCommands(bus, robot, controllers, profile.servo, self.chain.output_topic,
                                   profile.wheel_rate_per_speed, now, names)
        joints = [c.joint for c in controllers.controllers]
        joint_states = names.topic(f"{controllers.namespace}/joint_states")
        self.joint_states = JointStatePublisher(bus, scheduler, self.state, joints, controllers.joint_state_rate,
                                                joint_states)
        self.robot_state = RobotStatePublisher(bus, robot, joint_states, names, static_tf)
        self.odometry = OdometryPublisher(bus, scheduler, self.state, self.odometry_mode, names=names)
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

    def reset(self, seed: int) -> None:
        """Back to a fresh start: muxes idle, no held command, sensors' noise from `seed`."""
        self.chain.reset()
        for sensor in (self.lidar, self.camera):
            if sensor is not None:
                sensor.seed = seed

    def close(self) -> None:
        """Free the camera's GL context."""
        if self.camera is not None:
            self.camera.close()
            self.camera = None

    def topic(self, name: str) -> str:
        """One of this car's topics by its original name: car.topic("/scan") -> "/car2/scan"."""
        return self.names.topic(name)
