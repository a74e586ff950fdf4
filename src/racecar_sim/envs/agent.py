"""One car as an RL agent: its command goes in on the navigation mux input, its observation comes from its /scan,
its state and (when asked) its camera; its progress is measured along the centerline."""

from __future__ import annotations

import math

import numpy as np

from racecar_sim.core.names import NAVIGATION
from racecar_sim.core.time import to_ns
from racecar_sim.description.vehicle import VehicleGeometry
from racecar_sim.envs.reward import Centerline, Progress
from racecar_sim.envs.spaces import (
    IMAGE,
    SCAN,
    SPEED,
    SPEED_BOUND,
    STEERING,
    DriveLimits,
    action_space,
    observation_space,
    scan_observation,
    steering_from_hinges,
    to_command,
)
from racecar_sim.msgs import AckermannDrive, AckermannDriveStamped, Header, Image, LaserScan
from racecar_sim.runtime.car import Car
from racecar_sim.runtime.simulator import Simulator


def servo_geometry(car: Car) -> VehicleGeometry:
    """The geometry the car's servo_commands drives by (every car of the envs has one: the default CarNodes)."""
    assert car.servo is not None, f"{car.model_name} has no servo_commands"
    return car.servo.geometry


class CarAgent:
    """The env's side of one Car of a Simulator: commands, observations and progress."""

    def __init__(
        self,
        sim: Simulator,
        car: Car,
        action: str,
        limits: DriveLimits,
        camera: bool,
        centerline: Centerline | None,
        period_ns: int,
    ) -> None:
        if car.lidar is None:
            raise RuntimeError(f"{car.model_name} has no lidar: the driving envs observe its scan")
        self.sim, self.car, self.action, self.limits = sim, car, action, limits
        self.command_topic = car.topic(NAVIGATION)
        self.lidar = lidar = car.lidar
        self.range_max = lidar.spec.range_max
        self.camera = car.camera if camera else None
        self.observation_space = observation_space(lidar.spec, self.camera.spec if self.camera else None)
        self.action_space = action_space(action, limits)
        self.progress = Progress(centerline)
        geometry = servo_geometry(car)
        front = [w for w in geometry.wheels if w.hinge_joint]
        self._hinge_qpos, _ = car.state.joint_indices([w.hinge_joint for w in front if w.hinge_joint])
        self._hinge_points = np.array([w.hinge_axis_point for w in front], np.float64)
        self._wheelbase, self._servo = geometry.wheelbase, car.profile.servo
        self._ranges: np.ndarray | None = None
        self._image: np.ndarray | bytes | None = None  # the camera publishes its pixels as an array
        # When every control step ends on a scan's stamp, the latest /scan is the one cast at the step's end: cast
        # it then (the same ranges: a scan's noise depends on its stamp only), not the one in between as well.
        self._scan_at_step_end = period_ns % to_ns(1.0 / lidar.spec.update_rate) == 0
        if not self._scan_at_step_end:
            sim.subscribe(lidar.topic, self._on_scan)
        if self.camera is not None:
            sim.subscribe(self.camera.spec.image_topic, self._on_image)

    def _on_scan(self, msg: LaserScan) -> None:
        self._ranges = msg.ranges

    def _on_image(self, msg: Image) -> None:
        self._image = msg.data

    def fresh_sensors(self) -> None:
        """Take the sensors' readings at the current pose (after a reset: nothing of the last episode is kept), as
        the sensors would publish them stamped now."""
        now = self.sim.time_ns
        self._ranges = self.lidar.scan(now)
        if self.camera is not None:
            self._image = self.camera.capture(now)

    def after_step(self) -> None:
        """The control step is over: take the scan due now, when the lidar's schedule puts one here."""
        if self._scan_at_step_end:
            self._ranges = self.lidar.scan(self.sim.time_ns)

    def send(self, action: np.ndarray) -> None:
        """Publish the action as an AckermannDriveStamped on the car's navigation mux input."""
        speed, steering = to_command(action, self.action, self.limits)
        drive = AckermannDrive(steering_angle=float(steering), speed=float(speed))
        self.sim.publish(self.command_topic, AckermannDriveStamped(Header.at(self.sim.time_ns), drive))

    def pose(self) -> tuple[float, float, float]:
        """x, y (m) and yaw (rad) of base_link."""
        pos, quat = self.car.state.base_pose()
        w, x, y, z = quat
        return float(pos[0]), float(pos[1]), math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))

    def speed(self) -> float:
        """Forward speed of base_link, m/s."""
        linear, _ = self.car.state.base_velocity(local=True)
        return float(linear[0])

    def steering(self) -> float:
        """The measured steering angle (spaces.steering_from_hinges), rad."""
        hinges = self.sim.data.qpos[self._hinge_qpos]
        return float(steering_from_hinges(hinges, self._hinge_points, self._wheelbase, self._servo))

    def observation(self) -> dict[str, np.ndarray]:
        """The observation Dict (new arrays: the caller may keep them)."""
        assert self._ranges is not None, "reset() takes the first scan"
        obs = {
            SCAN: scan_observation(self._ranges, self.range_max),
            SPEED: np.array([min(max(self.speed(), -SPEED_BOUND), SPEED_BOUND)], np.float32),
            STEERING: np.array([self.steering()], np.float32),
        }
        if self.camera is not None:
            image = np.asarray(self._image, np.uint8).reshape(self.camera.spec.height, self.camera.spec.width, 3)
            obs[IMAGE] = np.ascontiguousarray(image[..., ::-1]) if self.camera.spec.encoding == "bgr8" else image.copy()
        return obs

    def reset_progress(self) -> None:
        """Measure progress from the current pose."""
        x, y, _ = self.pose()
        self.progress.reset(x, y)

    def step_progress(self) -> float:
        """Metres of progress since the last call."""
        return self.progress.step(*self.pose())
