"""Crashes: cars touching walls, obstacles and each other, read from MuJoCo's contact list after each stretch of
physics (at event rate, never per physics step; physics/crash_contacts.py says what counts).

Each crash is announced once, when it starts, on /racecar_sim/collisions (std_msgs/String: "carA carB" for two cars,
"carA <model>::<link>" for a wall or an obstacle) and kept in `crashes` for the run's summary; two cars starting to
touch also go to the hooks given to Simulator.on_collision. A car scraping along a wall is one crash: a new wall
crash of that car starts only after WALL_GAP of sim time without touching any. So is a car pushing another (their
contact flickers as they bounce): a new crash of the pair starts only after WALL_GAP without their touching.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import mujoco

from racecar_sim.bus import BusPort
from racecar_sim.core.time import to_ns
from racecar_sim.msgs import String
from racecar_sim.nodes import NodeBase
from racecar_sim.physics.crash_contacts import CrashContacts

COLLISIONS = "/racecar_sim/collisions"  # std_msgs/String "carA carB", or "carA <what it hit>"
WALL_GAP = 1.0  # s without touching a wall (or the same other car) before the car's next crash into it counts
MAX_KEPT = 10_000  # crashes kept for the summary (a long run that keeps crashing must not grow without bound)


@dataclass(frozen=True)
class Collision:
    """Two cars started touching at sim time `time_ns` (names: namespaces, "racecar" for the unnamed car)."""

    time_ns: int
    cars: tuple[str, str]


@dataclass(frozen=True)
class Crash:
    """A car started touching something at sim time `time_ns`: another car, or a wall or obstacle (`what`: its Gazebo
    model::link name), `kind` "car" or "wall"."""

    time_ns: int
    car: str
    what: str
    kind: str


@dataclass(frozen=True)
class WatchedCar:
    """A car as the crash watch needs it: its model name, root body and wheel bodies in the compiled model."""

    name: str
    root: int
    wheels: tuple[int, ...]


class Crashes(NodeBase):
    """The crash watch of the world; `check()` after the physics has moved announces the crashes that started."""

    def __init__(self, bus: BusPort, now: Callable[[], int]) -> None:
        self.bus, self.now = bus, now
        self.hooks: list[Callable[[Collision], None]] = []
        self.crashes: list[Crash] = []
        self.count = 0  # every crash, kept or not
        self._contacts: CrashContacts | None = None
        self._cars: list[WatchedCar] = []
        self._data: mujoco.MjData | None = None
        self._model: mujoco.MjModel | None = None
        self._last_pair: dict[tuple[int, int], int] = {}  # (car, car) -> sim time they last touched
        self._last_wall: dict[int, int] = {}  # car -> sim time it last touched a wall
        self._gap = to_ns(WALL_GAP)

    def watch(self, model: mujoco.MjModel, data: mujoco.MjData, cars: Sequence[WatchedCar], known: bool) -> None:
        """Watch these cars in this model. `known`: what touches now is not announced (a model spawned or deleted),
        else the first check announces it (a start)."""
        self._cars, self._model, self._data = list(cars), model, data
        roots = [car.root for car in cars]
        wheels = [w for car in cars for w in car.wheels]
        if self._contacts is None:
            self._contacts = CrashContacts(model, roots, wheels)
        else:
            self._contacts.rebind(model, roots, wheels)
        self._last_pair, self._last_wall = {}, {}
        if known:
            now = self.now()
            for a, b, _ in self._contacts.touching(data):
                if b >= 0:
                    self._last_pair[(a, b)] = now
                else:
                    self._last_wall[a] = now

    def check(self) -> None:
        """Announce the crashes that started since the last check."""
        if self._contacts is None or self._data is None:
            return
        touching = self._contacts.touching(self._data)
        if not touching:  # most checks: nothing to announce, nothing to remember
            return
        now = self.now()
        pairs: set[tuple[int, int]] = set()
        walls: dict[int, int] = {}
        for a, b, geom in sorted(touching):
            if b >= 0:
                pairs.add((a, b))
            elif a not in walls:
                walls[a] = geom
        for a, b in sorted(pairs):
            last = self._last_pair.get((a, b))
            if last is None or now - last > self._gap:
                names = (self._cars[a].name, self._cars[b].name)
                self._announce(Crash(now, names[0], names[1], "car"), " ".join(names))
                for hook in self.hooks:
                    hook(Collision(now, names))
            self._last_pair[(a, b)] = now
        for car, geom in walls.items():
            last = self._last_wall.get(car)
            if last is None or now - last > self._gap:
                what = self._thing(geom)
                self._announce(Crash(now, self._cars[car].name, what, "wall"), f"{self._cars[car].name} {what}")
            self._last_wall[car] = now

    def _announce(self, crash: Crash, text: str) -> None:
        self.count += 1
        if len(self.crashes) < MAX_KEPT:
            self.crashes.append(crash)
        self.bus.publish(COLLISIONS, String(text))

    def _thing(self, geom: int) -> str:
        """What a car hit, as Gazebo names it: the geom's model::link (its name up to the collision's own), or its
        body's name."""
        model = self._model
        assert model is not None
        name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_GEOM, geom) or ""
        if name:
            return name.rsplit("/", 1)[0]
        body = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, int(model.geom_bodyid[geom])) or ""
        return body or "the world"

    def crashes_of(self, car: str) -> list[Crash]:
        """The crashes of one car (by model name): into walls and obstacles, and into cars on either side."""
        return [c for c in self.crashes if c.car == car or (c.kind == "car" and c.what == car)]

    def reset(self, seed: int) -> None:
        self._last_pair, self._last_wall = {}, {}
        self.crashes, self.count = [], 0
