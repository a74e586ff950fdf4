"""servo_commands: turn the mux output (AckermannDriveStamped) into the six joint controller commands.

Profiles (profiles.yaml):
  ackermann  the seed: hinge angles from formula (2) and one speed per wheel so that no wheel slips,
             `speed` being the ground speed of base_link (the rear-axle centre).
  parallel   the original servo_commands.py: every wheel gets speed * wheel_rate_per_speed rad/s and both
             hinges get the same angle.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from racecar_sim.bus import Bus
from racecar_sim.control.controllers import ControllerConfig
from racecar_sim.control.mux import accept_command
from racecar_sim.core.names import CarNames
from racecar_sim.core.throttle import ThrottledWarning
from racecar_sim.description.urdf import Robot
from racecar_sim.description.vehicle import VehicleGeometry
from racecar_sim.msgs import AckermannDriveStamped, Float64

log = logging.getLogger("racecar_sim.servo_commands")


@dataclass(frozen=True)
class WheelCommand:
    """Where one wheel's command goes, and what the ackermann law needs to know about the wheel."""

    topic: str
    centre: np.ndarray  # tyre centre in base_link (x, y), zero steer
    hinge_topic: str | None
    hinge: np.ndarray | None  # steering axis (x, y)
    hinge_limits: tuple[float, float] | None


class ServoCommands:
    """The servo_commands node for one profile."""

    def __init__(self, bus: Bus, robot: Robot, controllers: ControllerConfig, mode: str, input_topic: str,
                 wheel_rate_per_speed: float | None = None, now: Callable[[], int] = lambda: 0,
                 names: CarNames = CarNames()) -> None:
        if mode not in ("ackermann", "parallel"):
            raise ValueError(f"servo mode '{mode}' is not ackermann or parallel")
        self.bus, self.mode = bus, mode
        self.geometry = VehicleGeometry.from_robot(robot)
        self.rate_per_speed = wheel_rate_per_speed or 1.0 / self.geometry.wheel_radius
        self.wheels = []
        for w in self.geometry.wheels:
            hinge_topic = hinge_limits = None
            if w.hinge_joint:
                hinge_topic = names.topic(controllers.controller(w.hinge_joint).command_topic)
                joint = robot.joints[w.hinge_joint]
                if joint.type == "revolute":
                    hinge_limits = (joint.limit.lower, joint.limit.upper)
            self.wheels.append(WheelCommand(names.topic(controllers.controller(w.joint).command_topic),
                                            np.array(w.centre[:2]),
                                            hinge_topic, np.array(w.hinge_axis_point) if w.hinge_axis_point else None,
                                            hinge_limits))
        self.max_curvature = self._max_curvature()
        # each wheel's numbers as Python floats, for ackermann() at every command: (topic, centre x, y, hinge topic,
        # hinge x, y or None, hinge limits or None)
        self._plain = [(w.topic, *w.centre.tolist(), w.hinge_topic,
                        None if w.hinge is None else tuple(w.hinge.tolist()), w.hinge_limits) for w in self.wheels]
        self._warned = False
        self.input_topic = input_topic
        self.warn = ThrottledWarning(log, now)
        bus.subscribe(input_topic, self._on_drive, AckermannDriveStamped)

    def _max_curvature(self) -> float:
        """The tightest turn whose inner hinge angle stays within its joint limit (formula (2) solved for 1/R)."""
        limit = math.inf
        for w in self.wheels:
            if w.hinge is not None and w.hinge_limits is not None:
                for bound in w.hinge_limits:
                    t = abs(math.tan(bound))
                    limit = min(limit, t / (w.hinge[0] + abs(w.hinge[1]) * t))
        return limit

    def _on_drive(self, msg: AckermannDriveStamped) -> None:
        if not accept_command(self.input_topic, msg, self.warn):
            return
        speed, steer = msg.drive.speed, msg.drive.steering_angle
        commands = self.parallel(speed, steer) if self.mode == "parallel" else self.ackermann(speed, steer)
        publish = self.bus.publish
        for topic, value in commands:
            publish(topic, Float64(value if type(value) is float else float(value)))

    def parallel(self, speed: float, steer: float) -> list[tuple[str, float]]:
        """The original: one wheel rate for all, one angle for both hinges."""
        out = [(w.topic, speed * self.rate_per_speed) for w in self.wheels]
        out += [(w.hinge_topic, steer) for w in self.wheels if w.hinge_topic]
        return out

    def ackermann(self, speed: float, steer: float) -> list[tuple[str, float]]:
        """Formula (2) for each hinge; each wheel turns at the rate its contact point moves over the ground."""
        kappa = math.tan(steer) / self.geometry.wheelbase  # path curvature of base_link, 1/R
        if abs(kappa) > self.max_curvature:
            if not self._warned:
                self._warned = True
                log.warning("servo_commands: steering_angle %.3f rad needs a hinge past its limit; "
                            "turning as tight as the limits allow", steer)
            kappa = math.copysign(self.max_curvature, kappa)
        yaw_rate = speed * kappa
        radius = self.geometry.wheel_radius
        out = []
        for topic, cx, cy, hinge_topic, hinge, limits in self._plain:
            heading, c, s = 0.0, 1.0, 0.0  # c, s: cos and sin of the heading (exactly these at 0)
            if hinge is not None:
                hx, hy = hinge
                # atan(L / (R - y_hinge)), written with curvature so that straight ahead needs no special case
                heading = math.atan2(hx * kappa, 1.0 - kappa * hy)
                if heading > math.pi / 2:
                    heading -= math.pi
                elif heading < -math.pi / 2:
                    heading += math.pi
                if limits:
                    heading = min(max(heading, limits[0]), limits[1])
                c, s = math.cos(heading), math.sin(heading)
                ox, oy = cx - hx, cy - hy
                cx, cy = hx + (c * ox - s * oy), hy + (s * ox + c * oy)  # the tyre centre, turned about the hinge
                out.append((hinge_topic, heading))
            # velocity of the tyre's ground point, projected on the wheel's heading
            vx, vy = speed - yaw_rate * cy, yaw_rate * cx
            out.append((topic, (vx * c + vy * s) / radius))
        return out
