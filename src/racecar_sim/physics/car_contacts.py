"""Which cars touch each other: read from MuJoCo's contact list at event rate, never per physics step."""

from __future__ import annotations

import mujoco
import numpy as np


class CarContacts:
    """Maps every geom to the car it belongs to (by the car's root body) and lists the touching car pairs."""

    def __init__(self, model: mujoco.MjModel, car_roots: list[int]) -> None:
        self.rebind(model, car_roots)

    def rebind(self, model: mujoco.MjModel, car_roots: list[int]) -> None:
        """Map the geoms of a recompiled model (a model was spawned or deleted); `car_roots` in the cars' order."""
        car_of_root = np.full(model.nbody, -1, dtype=np.int64)
        for index, body in enumerate(car_roots):
            car_of_root[body] = index
        self._car_of_geom = car_of_root[model.body_rootid[model.geom_bodyid]]

    def pairs(self, data: mujoco.MjData) -> set[tuple[int, int]]:
        """(i, j), i < j, for every two cars in contact now."""
        if data.ncon == 0:
            return set()
        cars = self._car_of_geom[data.contact.geom[: data.ncon]]
        touching = (cars[:, 0] >= 0) & (cars[:, 1] >= 0) & (cars[:, 0] != cars[:, 1])
        return {(int(min(a, b)), int(max(a, b))) for a, b in cars[touching]}
