"""joint_state_controller: /racecar/joint_states at the rate racecar_control.yaml gives (50 Hz)."""

from __future__ import annotations

from typing import Any, Protocol

from racecar_sim.bus import BusPort
from racecar_sim.msgs import Header, JointState
from racecar_sim.nodes import Timers
from racecar_sim.physics.state import CarState


class Outlet(Protocol):
    """What the publisher needs of the bus: the bus itself, or the controller_manager's muted stand-in while
    joint_state_controller is stopped."""

    def publish(self, topic: str, msg: Any) -> None: ...

    def has_listeners(self, topic: str) -> bool: ...

    def tally(self, topic: str, msgtype: type) -> None: ...

    def listeners_epoch(self) -> int | None: ...


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
        # (the outlet, its listeners epoch, has_listeners(topic) then): asked again only once a listener came or went
        self._heard: tuple[object, int | None, bool] = (None, None, True)
        scheduler.every(rate, self.publish, "joint_state_controller", unheard=self._unheard)

    def publish(self, now_ns: int) -> None:
        if self._unheard(now_ns):
            return
        position, velocity, effort = self.state.joint_state(*self._adr)
        self.bus.publish(self.topic, JointState(Header.at(now_ns), list(self.names), position, velocity, effort))

    def _unheard(self, _now_ns: int) -> bool:
        """Nobody would receive the message (robot_state_publisher listens only for /tf's listeners): counted, not
        built, and the physics need not stop for it."""
        bus = self.bus
        epoch = bus.listeners_epoch()
        outlet, known, heard = self._heard
        if epoch is None or known != epoch or outlet is not bus:
            heard = bus.has_listeners(self.topic)
            self._heard = (bus, epoch, heard)
        if heard:
            return False
        bus.tally(self.topic, JointState)
        return True
