"""The node contract: everything that lives on the bus for a car or for the world is a node.

A node is built from a `NodeContext` - the bus, the timers, the MuJoCo model and data, the car's names, its noise
seed, its description and state - and has three hooks, which its owner (a car, the world) calls for every node it
holds, in order, so that nobody fans a hook out by hand:

  reset(seed)          sim time went back to 0 (Simulator.reset): drop held state, take the new noise seed
  rebind(model, data)  a model spawned or deleted at run time replaced the model: read ids and addresses again
                       (a sensor's parts are bound for it: nodes/parts.py)
  close()              the Simulator is closed or the car deleted: free what the node holds (GL contexts, timers)

Timers and subscriptions made through the context's bus and timers are released by the owner when the car is
deleted; a node need not undo them itself. A user's node (a driver written in Python) uses the same contract:
subclass `NodeBase`, take the context in `__init__`, and override the hooks that matter.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Protocol, runtime_checkable

import mujoco

from racecar_sim.bus import BusPort
from racecar_sim.core.names import CarNames
from racecar_sim.nodes.parts import Parts

if TYPE_CHECKING:
    from racecar_sim.description.controllers import ControllerConfig
    from racecar_sim.description.urdf import Robot
    from racecar_sim.msgs import TransformStamped
    from racecar_sim.physics.state import CarState


class Cancellable(Protocol):
    """A scheduled task: cancel() stops it."""

    def cancel(self) -> None: ...


class Restartable(Cancellable, Protocol):
    """A one-shot timer restarted far more often than it fires (a mux input's timeout)."""

    @property
    def due_ns(self) -> int | None: ...

    def restart(self, time_ns: int) -> None: ...

    def stop(self) -> None: ...


class Timers(Protocol):
    """Sim-time timers: periodic tasks at exact multiples of their period, one-shots, restartable timeouts."""

    step_ns: int

    def every(
        self,
        rate_hz: float,
        callback: Callable[[int], None],
        name: str,
        start_ns: int = 0,
        unheard: Callable[[int], bool] | None = None,
    ) -> Cancellable: ...

    def at(self, time_ns: int, callback: Callable[[int], None], name: str) -> Cancellable: ...

    def timeout(self, callback: Callable[[int], None], name: str) -> Restartable: ...


class StaticTf(Protocol):
    """/tf_static for every car: transforms added to the one latched message."""

    def add(self, transforms: list[TransformStamped]) -> None: ...


@runtime_checkable
class Node(Protocol):
    """What a car or the world calls on each node it holds."""

    def reset(self, seed: int) -> None: ...

    def rebind(self, model: mujoco.MjModel, data: mujoco.MjData) -> None: ...

    def close(self) -> None: ...


class NodeBase:
    """A node whose hooks do nothing: subclass it and override those that matter to yours."""

    def reset(self, seed: int) -> None:
        """Sim time went back to 0 (and `seed` is the run's noise seed from now on)."""

    def rebind(self, model: mujoco.MjModel, data: mujoco.MjData) -> None:
        """A recompiled model replaced the old one (a model was spawned or deleted)."""

    def close(self) -> None:
        """The node's owner is going away: free what it holds."""


@dataclass(frozen=True)
class Mount:
    """What a node's `prepare` step needs to put its parts (sites, MuJoCo sensors and cameras, actuators) into the
    MjSpec before the model is compiled: the car's description, its names and its controller configuration."""

    robot: Robot
    names: CarNames
    controllers: ControllerConfig | None = None


@dataclass
class NodeContext:
    """Everything a node is built from.

    bus, timers: the car's (or the world's) view of the bus and the scheduler; what a car's nodes subscribe, offer and
        schedule through them is released when the car is deleted.
    model, data: the MuJoCo model and data (the owner keeps these current across a rebind).
    names: the car's names (topics, frames, MuJoCo names; `CarNames()` for the world and the unnamed car).
    seed: the run's noise seed; noise: whether sensors add the noise their description declares.
    now: sim time in ns.
    robot, state, controllers: the car's parsed description, its state access and its controller configuration (None
        for a node of the world).
    static_tf: the shared /tf_static publisher.
    parts: the MuJoCo parts of the node being built, bound to the compiled model (nodes/parts.py); its owner sets
        them before building each sensor, and binds them again after every recompile.
    """

    bus: BusPort
    timers: Timers
    model: mujoco.MjModel
    data: mujoco.MjData
    names: CarNames
    seed: int
    now: Callable[[], int]
    noise: bool = True
    robot: Robot | None = None
    state: CarState | None = None
    controllers: ControllerConfig | None = None
    static_tf: StaticTf | None = None
    parts: Parts = field(default_factory=Parts)

    @property
    def scheduler(self) -> Timers:
        """The timers, under the name the Simulator's own attribute has (`sim.scheduler`)."""
        return self.timers

    def noise_stream(self, kind: str) -> str:
        """The key of one of this car's noise streams (`scan`, `camera`, ...): the unnamed car keeps the original keys,
        so its runs stay bit-identical."""
        return self.names.noise_prefix + kind

    def topic(self, name: str) -> str:
        """One of the car's topics by its original name (`/scan` -> `/car2/scan`)."""
        return self.names.topic(name)

    def need_robot(self, what: str) -> Robot:
        """The car's description, for a node that belongs to a car (`what` names it in the error)."""
        if self.robot is None:
            raise TypeError(f"{what} belongs to a car: its context has no robot description")
        return self.robot

    def need_state(self, what: str) -> CarState:
        """The car's state access, for a node that belongs to a car."""
        if self.state is None:
            raise TypeError(f"{what} belongs to a car: its context has no car state")
        return self.state
