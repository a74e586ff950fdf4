"""gazebo_ros's /clock: sim time published at pub_clock_frequency (100 Hz by default), so that nodes with
use_sim_time run on sim time. A world node: it belongs to the simulation, not to a car."""

from __future__ import annotations

from racecar_sim.bus import BusPort
from racecar_sim.core.names import CLOCK
from racecar_sim.msgs import Clock, Time
from racecar_sim.nodes import NodeBase, Timers

CLOCK_RATE = 100.0  # Hz of sim time: gazebo_ros's pub_clock_frequency default


class ClockPublisher(NodeBase):
    """rosgraph_msgs/Clock on /clock at CLOCK_RATE; a message nobody would receive is counted, not built."""

    def __init__(self, bus: BusPort, timers: Timers, rate: float = CLOCK_RATE) -> None:
        self.bus = bus
        self._task = timers.every(rate, self._publish, "clock", unheard=self._unheard)

    def _publish(self, now_ns: int) -> None:
        if not self._unheard(now_ns):
            self.bus.publish(CLOCK, Clock(Time.from_ns(now_ns)))

    def _unheard(self, _now_ns: int) -> bool:
        if self.bus.has_listeners(CLOCK):
            return False
        self.bus.tally(CLOCK, Clock)
        return True

    def close(self) -> None:
        self._task.cancel()
