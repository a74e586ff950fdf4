"""The command path of N cars as array code: an Ackermann command per world -> the actuator setpoints (ctrl).

It is what the single car's node chain does to a command published on the navigation mux input: the high-level
mux (Navigation 0) and the low-level mux (Navigation) forward it at once, servo_commands turns it into the four
wheel rates and two hinge angles (the profile's law, control/servo_law.py, the very function the node calls), and
the controller commands are clamped as ros_control's controllers clamp them (control/commands.py) before they
become MuJoCo setpoints.

Read from a started Car, so that the law, gains, limits and actuator addresses are the single car's own.
"""

from __future__ import annotations

import math

import numpy as np

from racecar_sim.runtime.car import Car


class BatchCommands:
    """servo_commands and the controller commands of one car, vectorised over a batch of worlds."""

    def __init__(self, car: Car) -> None:
        servo = car.servo
        if servo is None:
            raise ValueError(f"{car.model_name}: the batch drives the car through servo_commands, which it lacks")
        self.law = servo.law
        limits = car.commands.limits
        self.nu = car.state.model.nu
        by_topic = {car.names.topic(c.command_topic): c.name for c in car.controllers.controllers}
        # per output of the law: the controller's ctrl addresses and its command limits (lo, hi)
        self._targets: list[tuple[list[int], float, float]] = []
        for topic in servo.topics:
            lo, hi = limits.get(by_topic[topic], (-math.inf, math.inf))
            self._targets.append((car.state.actuator_ctrl(by_topic[topic]), lo, hi))

    def ctrl(self, speed: np.ndarray, steer: np.ndarray, ctrl: np.ndarray) -> None:
        """Write the setpoints for commands (speed m/s, steering_angle rad), one per world, into `ctrl` (N, nu)."""
        values, _ = self.law.commands(speed, steer)
        for value, (addresses, lo, hi) in zip(values, self._targets):
            clamped = np.minimum(np.maximum(value, lo), hi)
            for adr in addresses:
                ctrl[:, adr] = clamped
