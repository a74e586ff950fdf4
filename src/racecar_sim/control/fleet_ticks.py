"""A fleet's publishers of one kind ticking together: the cars of one live MjData whose tasks fall at the same times.

The cars of a fleet built together tick at the same sim times. Where only a recorder takes what they publish, the
first car to tick hands over every car's messages in one go (their numbers, for the writer to pack), and the others'
tasks at that time do nothing: one hand-over per tick instead of one per car. The messages are the same either way;
what changes, against every car publishing at its own tick, is only their order among other topics within a tick:
every car's come at the first car's. Used by the controller states (control/controller_state.py) and the joint states
(control/joint_state_controller.py).
"""

from __future__ import annotations

import weakref
from typing import Any, Protocol

import mujoco

from racecar_sim.core.time import NS_PER_S


class _Publisher(Protocol):
    """What a member needs of its publisher: the car state whose live MjData it reads."""

    @property
    def state(self) -> Any: ...


class FleetTicks:
    """The members of one kind of publisher (FleetTick) per live MjData, in the order they first ticked with it; held
    weakly, so that a publisher (whose car state holds the MjData) never keeps its own entry alive."""

    def __init__(self) -> None:
        self._fleets: weakref.WeakKeyDictionary[mujoco.MjData, list[weakref.ref[FleetTick]]] = (
            weakref.WeakKeyDictionary()
        )

    def fleet(self, data: mujoco.MjData) -> list[weakref.ref[FleetTick]]:
        """The members that ticked with `data` (a recompiled model's new MjData gives a new fleet)."""
        return self._fleets.setdefault(data, [])


class FleetTick:
    """One publisher's place in its fleet's ticks, at `rate_hz` on physics steps of `step_ns`. Its ticks are shared
    only where each is a whole number of physics steps, so that two cars that tick at the same time once tick together
    at every time after (`together`)."""

    def __init__(self, fleets: FleetTicks, publisher: _Publisher, rate_hz: float, step_ns: int) -> None:
        period = NS_PER_S / rate_hz
        self.publisher = publisher
        self.together = period.is_integer() and int(period) % step_ns == 0
        self._fleets = fleets
        self._joined: object = None  # the MjData whose fleet it joined, and that fleet
        self._fleet: list[weakref.ref[FleetTick]] = []
        self.last_tick: int | None = None  # the last time it was published (by itself or with the fleet)
        self.published_at: int | None = None  # the last time a fleet's first car published for it

    def published(self, now_ns: int) -> bool:
        """Whether its fleet's first car published for it at this tick: its own task then does nothing."""
        return self.published_at == now_ns

    def ticking(self, now_ns: int) -> list[Any]:
        """At its tick `now_ns`: the publishers of its fleet that tick now, in the fleet's order, itself among them,
        each marked as published now (published() is then True for the others); [] where it ticks alone (its first
        tick, no other car ticked with it last time, or its ticks may not be shared)."""
        if not self.together:
            return []
        data = self.publisher.state.data
        fleet = self._fleet
        if self._joined is not data:  # its first tick with this data
            fleet = self._fleet = self._fleets.fleet(data)
            self._joined = data
            fleet.append(weakref.ref(self))
        previous, self.last_tick = self.last_tick, now_ns
        if previous is None or len(fleet) < 2:
            return []
        # those that ticked with it last time (a deleted car's task is cancelled and its data is the old model's)
        ticking = [
            member
            for member in (ref() for ref in fleet)
            if member is self
            or (member is not None and member.last_tick == previous and member.publisher.state.data is data)
        ]
        if len(ticking) < 2:
            return []
        for member in ticking:
            member.last_tick = member.published_at = now_ns
        return [member.publisher for member in ticking]

    def reset(self) -> None:
        """Sim time went back to 0: the ticks it was published at are forgotten (the fleet ticks afresh)."""
        self.last_tick = self.published_at = None
