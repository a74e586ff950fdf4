"""How often one car crashed in an episode: envs.crash's contact test, sampled at its rate and counted."""

from __future__ import annotations

import mujoco

from racecar_sim.description.vehicle import VehicleGeometry
from racecar_sim.runtime import Car

CHECK_RATE = 100.0  # Hz, envs.crash's: on the /clock ticks, so no physics step is split for it
SEPARATION_NS = 500_000_000  # a car pressed on a wall bounces on and off it: one crash until 0.5 s without a touch


class CrashCounter:
    """Counts the crashes of `car`: touches of a wall, an obstacle or another car, as the Gymnasium env ends an
    episode on (envs.crash.CrashMonitor), at least 0.5 s apart (one pressed against a wall flickers on and off).

    Call `update(data, now_ns)` at a fixed rate (CHECK_RATE); `count` is the number of crashes,
    `first_ns` the sim time of the first.
    """

    def __init__(self, model: mujoco.MjModel, car: Car) -> None:
        from racecar_sim.envs.crash import CrashMonitor  # gymnasium loads only when an episode runs

        geometry = VehicleGeometry.from_robot(car.robot)
        self._monitor = CrashMonitor.for_cars(model, [(car.names, car.robot.root, geometry)])
        self._last_ns: int | None = None
        self.count = 0
        self.first_ns: int | None = None

    def update(self, data: mujoco.MjData, now_ns: int) -> None:
        """Sample the contacts now; a crash counts once, however long it lasts."""
        self._monitor.clear()
        self._monitor.check(data)
        if not self._monitor.crashed(0):
            return
        if self._last_ns is None or now_ns - self._last_ns >= SEPARATION_NS:
            self.count += 1
            if self.first_ns is None:
                self.first_ns = now_ns
        self._last_ns = now_ns
