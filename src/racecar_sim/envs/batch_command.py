"""The command path of N cars as array code: an Ackermann command per world -> the actuator setpoints (ctrl).

It is what the single car's node chain does to a command published on the navigation mux input: the high-level
mux (Navigation 0) and the low-level mux (Navigation) forward it at once, servo_commands turns it into the four
wheel rates and two hinge angles (control/servo.py, the profile's law), and the controller commands are
clamped as ros_control's controllers clamp them (control/commands.py) before they become MuJoCo setpoints.

Read from a started Car, so that the geometry, gains, limits and actuator addresses are the single car's own.
"""

from __future__ import annotations

import math

import numpy as np

from racecar_sim.control.servo import ServoCommands
from racecar_sim.runtime.car import Car


def _libm(function, arity: int = 1):
    """`function` (math's) over arrays: numpy's own tan and arctan2 differ from libm in the last bit for some
    inputs, and servo_commands computes with math; a wheel rate one ulp off would make the worlds drift."""
    ufunc = np.frompyfunc(function, arity, 1)
    return lambda *args: ufunc(*args).astype(np.float64)


_tan, _atan2, _cos, _sin = _libm(math.tan), _libm(math.atan2, 2), _libm(math.cos), _libm(math.sin)


class BatchCommands:
    """servo_commands and the controller commands of one car, vectorised over a batch of worlds."""

    def __init__(self, car: Car) -> None:
        servo: ServoCommands = car.servo
        self.mode, self.max_curvature = servo.mode, servo.max_curvature
        self.rate_per_speed = servo.rate_per_speed
        self.wheelbase, self.radius = servo.geometry.wheelbase, servo.geometry.wheel_radius
        self.wheels = servo.wheels
        by_topic = {car.names.topic(c.command_topic): c.name for c in car.controllers.controllers}
        limits = car.commands.limits
        self.nu = car.state.model.nu
        self._targets: dict[str, tuple[list[int], float, float]] = {}  # topic -> ctrl addresses, lo, hi
        for topic, name in by_topic.items():
            lo, hi = limits.get(name, (-math.inf, math.inf))
            self._targets[topic] = (car.state.actuator_ctrl(name), lo, hi)

    def ctrl(self, speed: np.ndarray, steer: np.ndarray, ctrl: np.ndarray) -> None:
        """Write the setpoints for commands (speed m/s, steering_angle rad), one per world, into `ctrl` (N, nu)."""
        commands = self._parallel(speed, steer) if self.mode == "parallel" else self._ackermann(speed, steer)
        for topic, value in commands:
            addresses, lo, hi = self._targets[topic]
            clamped = np.minimum(np.maximum(value, lo), hi)
            for adr in addresses:
                ctrl[:, adr] = clamped

    def _parallel(self, speed: np.ndarray, steer: np.ndarray) -> list[tuple[str, np.ndarray]]:
        out = [(w.topic, speed * self.rate_per_speed) for w in self.wheels]
        return out + [(w.hinge_topic, steer) for w in self.wheels if w.hinge_topic]

    def _ackermann(self, speed: np.ndarray, steer: np.ndarray) -> list[tuple[str, np.ndarray]]:
        """ServoCommands.ackermann, formula by formula, over arrays."""
        kappa = _tan(steer) / self.wheelbase
        kappa = np.where(np.abs(kappa) > self.max_curvature, np.copysign(self.max_curvature, kappa), kappa)
        yaw_rate = speed * kappa
        out = []
        for w in self.wheels:
            heading = np.zeros_like(speed)
            cx, cy = np.full_like(speed, w.centre[0]), np.full_like(speed, w.centre[1])
            if w.hinge is not None:
                heading = _atan2(w.hinge[0] * kappa, 1.0 - kappa * w.hinge[1])
                heading = np.where(heading > math.pi / 2, heading - math.pi, heading)
                heading = np.where(heading < -math.pi / 2, heading + math.pi, heading)
                if w.hinge_limits:
                    heading = np.minimum(np.maximum(heading, w.hinge_limits[0]), w.hinge_limits[1])
                c, s = _cos(heading), _sin(heading)
                ox, oy = w.centre[0] - w.hinge[0], w.centre[1] - w.hinge[1]
                cx, cy = w.hinge[0] + (c * ox - s * oy), w.hinge[1] + (s * ox + c * oy)
                out.append((w.hinge_topic, heading))
            vx, vy = speed - yaw_rate * cy, yaw_rate * cx
            out.append((w.topic, (vx * _cos(heading) + vy * _sin(heading)) / self.radius))
        return out
