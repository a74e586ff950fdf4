"""Cars touching cars: read from MuJoCo's contact list after each stretch of physics (at event rate, never per physics
step), announced on /racecar_sim/collisions and to the hooks given to Simulator.on_collision when two cars start
touching. A world node: it exists while the world holds two cars or more."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import mujoco

from racecar_sim.bus import BusPort
from racecar_sim.msgs import String
from racecar_sim.nodes import NodeBase
from racecar_sim.physics.car_contacts import CarContacts

COLLISIONS = "/racecar_sim/collisions"  # std_msgs/String "carA carB" when two cars start touching


@dataclass(frozen=True)
class Collision:
    """Two cars started touching at sim time `time_ns` (names: namespaces, "racecar" for the unnamed car)."""

    time_ns: int
    cars: tuple[str, str]


class CarCollisions(NodeBase):
    """Which cars touch; `check()` after the physics has moved announces the pairs that started touching."""

    def __init__(self, bus: BusPort, now: Callable[[], int]) -> None:
        self.bus, self.now = bus, now
        self.hooks: list[Callable[[Collision], None]] = []
        self._contacts: CarContacts | None = None
        self._names: list[str] = []
        self._touching: set[tuple[int, int]] = set()
        self._data: mujoco.MjData | None = None

    @property
    def active(self) -> bool:
        """Whether there are two cars or more to watch."""
        return self._contacts is not None

    def watch(
        self, model: mujoco.MjModel, data: mujoco.MjData, roots: Sequence[int], names: Sequence[str], known: bool = True
    ) -> None:
        """Watch these cars (their root bodies and model names, in order) in this model. `known`: the pairs touching
        now are not announced (a model spawned or deleted); else the first check announces them (a start)."""
        self._names, self._data = list(names), data
        if len(roots) < 2:
            self._contacts, self._touching = None, set()
            return
        if self._contacts is None:
            self._contacts = CarContacts(model, list(roots))
        else:
            self._contacts.rebind(model, list(roots))
        self._touching = self._contacts.pairs(data) if known else set()

    def check(self) -> None:
        """Announce the car pairs that started touching since the last check."""
        if self._contacts is None or self._data is None:
            return
        touching = self._contacts.pairs(self._data)
        for a, b in sorted(touching - self._touching):
            event = Collision(self.now(), (self._names[a], self._names[b]))
            self.bus.publish(COLLISIONS, String(" ".join(event.cars)))
            for hook in self.hooks:
                hook(event)
        self._touching = touching

    def reset(self, seed: int) -> None:
        self._touching = set()
