"""The simplest driver: one constant command, repeated faster than the mux timeout."""

from __future__ import annotations

from racecar_sim.bus import BusPort
from racecar_sim.msgs import AckermannDrive, AckermannDriveStamped, Header
from racecar_sim.nodes import NodeBase, Timers

NAVIGATION = "/vesc/ackermann_cmd_mux/input/navigation"


class ConstantCommand(NodeBase):
    """Publishes speed/steering_angle at `rate` Hz on `topic` (the navigation input by default)."""

    def __init__(
        self,
        bus: BusPort,
        scheduler: Timers,
        speed: float,
        steering_angle: float,
        rate: float = 20.0,
        topic: str = NAVIGATION,
    ) -> None:
        self.bus, self.topic = bus, topic
        self.drive = AckermannDrive(steering_angle=steering_angle, speed=speed)
        scheduler.every(rate, self.publish, "constant_command")

    def publish(self, now_ns: int) -> None:
        self.bus.publish(self.topic, AckermannDriveStamped(Header.at(now_ns, "base_link"), self.drive))
