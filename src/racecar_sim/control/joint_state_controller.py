"""joint_state_controller: /racecar/joint_states at the rate racecar_control.yaml gives (50 Hz)."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, Literal, Protocol

from racecar_sim.bus import BusPort, ListenerAnswer, RowPacker
from racecar_sim.core.time import NS_PER_S
from racecar_sim.msgs import Header, JointState
from racecar_sim.msgs.cdr_layout import CdrLayout
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
        scheduler.every(rate, self.publish, "joint_state_controller", unheard=self._unheard)

    def publish(self, now_ns: int) -> None:
        if self._unheard(now_ns):
            return
        position, velocity, effort = self.state.joint_state(*self._adr)
        rows = self._rows(self.bus)
        if rows is not None:  # a recorder and robot_state's /tf alone take it: its numbers, for the writer to pack
            publish_fed_rows, layout, fed_type, fed_packer, fed_topics = rows
            sec, nanosec = divmod(now_ns, NS_PER_S)
            row = (sec, nanosec, *position.tolist(), *velocity.tolist(), *effort.tolist())
            publish_fed_rows(JointState, layout, (self.topic,), [row], ((fed_type, fed_packer, fed_topics, [row]),))
            return
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

    def _unheard(self, _now_ns: int) -> bool:
        """Nobody would receive the message (robot_state_publisher listens only for /tf's listeners): counted, not
        built, and the physics need not stop for it."""
        bus = self.bus
        if self._heard(bus):
            return False
        bus.tally(self.topic, JointState)
        return True
