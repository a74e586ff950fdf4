"""Crashes from MuJoCo's contact list: a car touching a wall, an obstacle or another car.

A contact of a car's geom with anything not of that car is a crash, except a wheel resting on a surface: a wheel
geom against a geom of the world whose contact normal is within 45 degrees of vertical (the ground, a floor
box, a ramp). Read at event rate (CHECK_RATE) and at the end of each control step, never per physics step.
"""

from __future__ import annotations

from collections.abc import Sequence

import mujoco
import numpy as np

from racecar_sim.core.names import CarNames
from racecar_sim.description.vehicle import VehicleGeometry

CHECK_RATE = 50.0  # Hz: on the /clock and joint_states ticks, so no physics step is split for it
SUPPORT_NORMAL_Z = 0.7071  # |n_z| above this: a wheel standing on the surface, not driving into it


class CrashMonitor:
    """Which cars have crashed since clear(), into the world (`wall`) or into which other cars (`cars`)."""

    def __init__(self, model: mujoco.MjModel, roots: Sequence[int], wheel_bodies: Sequence[int]) -> None:
        car_of_root = np.full(model.nbody, -1, np.int64)
        for index, body in enumerate(roots):
            car_of_root[body] = index
        self._car_of_geom = car_of_root[model.body_rootid[model.geom_bodyid]]
        wheel = np.zeros(model.nbody, bool)
        wheel[list(wheel_bodies)] = True
        self._wheel_geom = wheel[model.geom_bodyid]
        self.wall = np.zeros(len(roots), bool)
        self.cars: list[set[int]] = [set() for _ in roots]

    @classmethod
    def for_cars(cls, model: mujoco.MjModel, cars: Sequence[tuple[CarNames, str, VehicleGeometry]]) -> CrashMonitor:
        """A monitor for cars given as (names, root link, geometry), in order."""
        roots = [model.body(names.mj(root)).id for names, root, _ in cars]
        wheels = [model.body(names.mj(w.link)).id for names, _, geometry in cars for w in geometry.wheels]
        return cls(model, roots, wheels)

    def clear(self) -> None:
        """Forget every crash (a new episode)."""
        self.wall[:] = False
        for touched in self.cars:
            touched.clear()

    def check(self, data: mujoco.MjData, _now_ns: int = 0) -> None:
        """Add the crashes in the current contact list."""
        n = data.ncon
        if n == 0:
            return
        contact = data.contact
        geoms = contact.geom[:n]
        owner = self._car_of_geom[geoms]
        first, second = owner[:, 0], owner[:, 1]
        touching = first != second  # a car and something not of it (the world is -1 on both sides of its own)
        if not touching.any():
            return
        wheel = self._wheel_geom[geoms]
        on_surface = (wheel[:, 0] & (second < 0)) | (wheel[:, 1] & (first < 0))
        crash = touching & ~(on_surface & (np.abs(contact.frame[:n, 2]) > SUPPORT_NORMAL_Z))
        for index in np.flatnonzero(crash):
            for car, other in ((first[index], second[index]), (second[index], first[index])):
                if car < 0:
                    continue
                if other < 0:
                    self.wall[car] = True
                else:
                    self.cars[car].add(int(other))

    def crashed(self, index: int) -> bool:
        """Whether car `index` touched a wall, an obstacle or another car."""
        return bool(self.wall[index]) or bool(self.cars[index])
