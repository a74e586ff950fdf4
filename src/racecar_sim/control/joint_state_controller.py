"""joint_state_controller: /racecar/joint_states at the rate racecar_control.yaml gives (50 Hz).

A fleet's joint states of one tick are published together, at the first car's task (control/fleet_ticks.py): where a
recorder alone takes them (and robot_state_publisher's /tf of them), every car's joint state in one hand-over and
every car's /tf in another, not two per car.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, Literal, NamedTuple, Protocol

import numpy as np

from racecar_sim.bus import BusPort, ListenerAnswer, RowPacker
from racecar_sim.control.fleet_ticks import FleetTick, FleetTicks
from racecar_sim.core.time import NS_PER_S
from racecar_sim.msgs import Header, JointState
from racecar_sim.msgs.cdr_layout import CdrLayout, PackersByRow
from racecar_sim.nodes import Timers
from racecar_sim.physics.state import CarState


class Outlet(Protocol):
    """What the publisher needs of the bus: the bus itself, or the controller_manager's muted stand-in while
    joint_state_controller is stopped."""

    def publish(self, topic: str, msg: Any) -> None: ...

    def has_listeners(self, topic: str) -> bool: ...

    def tally(self, topic: str, msgtype: type) -> None: ...

    def listeners_epoch(self) -> int | None: ...


_FedRows = tuple[Callable[..., None], CdrLayout, type, RowPacker, tuple[str, ...]]
"""A bus's publish_fed_rows, the joint state's layout, and the class, packer and topics of what its feeder makes."""
_FLEETS = FleetTicks()  # the joint-state publishers of each live MjData


class _FleetRows(NamedTuple):
    """A fleet's joint states as rows (JointStatePublisher._publish_rows): what publishes them, the cars, their joint
    states' layout and topics, their /tf's class, packer (a PackersByRow) and topics."""

    publish: Callable[..., None]  # the first car's bus's publish_fed_rows
    cars: list[JointStatePublisher]
    model: object  # the model their joints' addresses are of
    qpos_adr: np.ndarray  # every car's joints' addresses, car after car
    dof_adr: np.ndarray
    spans: list[tuple[int, int]]  # each car's part of them
    layout: CdrLayout
    topics: tuple[str, ...]
    tf_type: type
    tf_packer: PackersByRow
    tf_topics: tuple[str, ...]


def _fleet_rows(cars: list[JointStatePublisher]) -> _FleetRows | None:
    """What publishes `cars`' joint states as rows, where a recorder alone takes every one (and /tf of them), their
    messages have one shape, and each car's /tf is one message; else None."""
    made = []
    for car in cars:
        rows = car._rows(car.bus)
        if rows is None:
            return None
        made.append(rows)
    _, layout, tf_type, _, _ = made[0]
    if any(fed_type is not tf_type or not other.packs_as(layout) for _, other, fed_type, _, _ in made):
        return None
    if any(len(topics) != 1 for *_, topics in made):
        return None
    spans, start = [], 0
    for car in cars:
        spans.append((start, start + len(car._adr[0])))
        start += len(car._adr[0])
    return _FleetRows(
        made[0][0],
        list(cars),
        cars[0].state.model,
        np.concatenate([car._adr[0] for car in cars]),
        np.concatenate([car._adr[1] for car in cars]),
        spans,
        layout,
        tuple(car.topic for car in cars),
        tf_type,
        PackersByRow(tuple(packer for *_, packer, _ in made)),
        tuple(topic for *_, (topic,) in made),
    )


class JointStatePublisher:
    """Position, velocity and effort of every joint that has a controller transmission."""

    def __init__(
        self,
        bus: BusPort,
        scheduler: Timers,
        state: CarState,
        joints: list[str],
        rate: float,
        topic: str = "/racecar/joint_states",
    ) -> None:
        self.bus: Outlet = bus
        self.state, self.topic = state, topic
        self.names = list(joints)
        self._adr = state.joint_indices(self.names)
        self._heard = ListenerAnswer(lambda: self.bus.has_listeners(self.topic))
        self._layout: CdrLayout | None | Literal[False] = False  # read off the first message (None: none holds it)
        self._rows = ListenerAnswer(self._fed_rows)
        self._ticks = FleetTick(_FLEETS, self, rate, scheduler.step_ns)
        self._together: _FleetRows | None = None  # the fleet it last published with, as rows
        scheduler.every(rate, self.publish, "joint_state_controller", unheard=self._skipped)

    def publish(self, now_ns: int) -> None:
        """The task at each tick: the joint state, published now, with the fleet's or on its own."""
        if self._ticks.published(now_ns):
            return  # published at this tick with the fleet's first car
        cars = self._ticks.ticking(now_ns)
        if not cars:
            self._publish_own(now_ns)
        elif not self._publish_rows(cars, now_ns):
            for car in cars:  # someone takes messages: each car publishes its own, in turn
                car._publish_own(now_ns)

    def reset(self) -> None:
        """Sim time went back to 0: the ticks it was published at are forgotten (the fleet's too: it ticks afresh)."""
        self._ticks.reset()

    def _row(self, now_ns: int) -> tuple[Any, ...]:
        """Its joint state's numbers now, in wire order: sec, nanosec, positions, velocities, efforts."""
        position, velocity, effort = self.state.joint_state(*self._adr)
        return (*divmod(now_ns, NS_PER_S), *position.tolist(), *velocity.tolist(), *effort.tolist())

    def _publish_rows(self, cars: list[JointStatePublisher], now_ns: int) -> bool:
        """Where a recorder alone takes every one of `cars`' joint states (and robot_state's /tf of them), publish them
        as rows: the joint states in one hand-over, their /tf in another (a packer per car). False, nothing
        published, where one needs a message object, or the cars' joint states differ in shape."""
        made = self._together
        if made is None or made.cars != cars or made.model is not self.state.model:
            made = self._together = _fleet_rows(cars)
            if made is None:
                return False
        elif any(car._rows(car.bus) is None for car in cars):  # the listeners changed
            self._together = None
            return False
        # every car's numbers read together (the cars share the MjData)
        position, velocity, effort = (a.tolist() for a in self.state.joint_state(made.qpos_adr, made.dof_adr))
        sec, nanosec = divmod(now_ns, NS_PER_S)
        rows = [(sec, nanosec, *position[a:b], *velocity[a:b], *effort[a:b]) for a, b in made.spans]
        fed = ((made.tf_type, made.tf_packer, made.tf_topics, list(enumerate(rows))),)
        made.publish(JointState, made.layout, made.topics, rows, fed)
        return True

    def _publish_own(self, now_ns: int) -> None:
        """Its own joint state, now, as a car on its own publishes it."""
        if self._unheard(now_ns):
            return
        rows = self._rows(self.bus)
        if rows is not None:  # a recorder and robot_state's /tf alone take it: its numbers, for the writer to pack
            publish_fed_rows, layout, fed_type, fed_packer, fed_topics = rows
            row = self._row(now_ns)
            publish_fed_rows(JointState, layout, (self.topic,), [row], ((fed_type, fed_packer, fed_topics, [row]),))
            return
        position, velocity, effort = self.state.joint_state(*self._adr)
        msg = JointState(Header.at(now_ns), list(self.names), position, velocity, effort)
        if self._layout is False:  # the first message: its shape is every message's (rows may go from the next)
            self._layout = CdrLayout.read(msg)
            self._rows.forget()
        self.bus.publish(self.topic, msg)

    def _fed_rows(self) -> _FedRows | None:
        """Where the topic's only takers are a recorder that takes rows and one subscriber that only feeds /tf, which
        only that recorder takes (Bus.sole_feeder: robot_state_publisher): the bus's publish_fed_rows, the joint
        state's layout, and the class, packer and topics of what the subscriber makes of each row. Asked again only
        when the bus's listeners change; None while a message object is needed (any other listener), or before the
        first message gave the layout."""
        bus = self.bus
        feeder = getattr(bus, "sole_feeder", None)  # not on a stopped controller's muted outlet
        if not self._layout or feeder is None:
            return None
        ask = getattr(feeder(self.topic), "joint_state_rows", None)
        fed = ask(self.names) if ask is not None else None
        if fed is None:
            return None
        return (bus.publish_fed_rows, self._layout, *fed)  # type: ignore[attr-defined]  # a BusPort's

    def _skipped(self, now_ns: int) -> bool:
        """The scheduler's question: _unheard(), unless the fleet's first car published it at this tick."""
        return not self._ticks.published(now_ns) and self._unheard(now_ns)

    def _unheard(self, _now_ns: int) -> bool:
        """Nobody would receive the message (robot_state_publisher listens only for /tf's listeners): counted, not
        built, and the physics need not stop for it."""
        bus = self.bus
        if self._heard(bus):
            return False
        bus.tally(self.topic, JointState)
        return True
