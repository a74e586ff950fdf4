"""gazebo_ros's /clock: sim time published at pub_clock_frequency (100 Hz by default), so that nodes with
use_sim_time run on sim time. A world node: it belongs to the simulation, not to a car."""

from __future__ import annotations

from racecar_sim.bus import BusPort, ListenerAnswer
from racecar_sim.core.names import CLOCK
from racecar_sim.core.time import NS_PER_S
from racecar_sim.msgs import Clock, Time
from racecar_sim.msgs.cdr_layout import CdrLayout
from racecar_sim.nodes import NodeBase, Timers

CLOCK_RATE = 100.0  # Hz of sim time: gazebo_ros's pub_clock_frequency default


class ClockPublisher(NodeBase):
    """rosgraph_msgs/Clock on /clock at CLOCK_RATE; a message nobody would receive is counted, not built."""

    def __init__(self, bus: BusPort, timers: Timers, rate: float = CLOCK_RATE) -> None:
        self.bus = bus
        self._layout: CdrLayout | None = None  # the CDR layout of a Clock, read off the first one published
        self._heard = ListenerAnswer(lambda: self.bus.has_listeners(CLOCK))
        self._bytes_alone = ListenerAnswer(lambda: self.bus.cdr_only(CLOCK))  # only a recorder takes it
        self._task = timers.every(rate, self._publish, "clock", unheard=self._unheard)

    def _publish(self, now_ns: int) -> None:
        if self._unheard(now_ns):
            return
        if self._layout is not None and self._bytes_alone(self.bus):  # only a recorder takes it: its bytes
            self.bus.publish_cdr(CLOCK, Clock, self._layout.pack(divmod(now_ns, NS_PER_S)))
            return
        msg = Clock(Time.from_ns(now_ns))
        if self._layout is None:
            self._layout = CdrLayout.read(msg)
        self.bus.publish(CLOCK, msg)

    def _unheard(self, _now_ns: int) -> bool:
        bus = self.bus
        if self._heard(bus):
            return False
        bus.tally(CLOCK, Clock)
        return True

    def close(self) -> None:
        self._task.cancel()
