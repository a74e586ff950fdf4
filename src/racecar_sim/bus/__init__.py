"""The in-process topic bus: the spine every node publishes to and subscribes from, with ROS-style services."""

from racecar_sim.bus.bus import Bus, RowPacker, ServiceError, Subscription, type_name
from racecar_sim.bus.listener_answer import ListenerAnswer
from racecar_sim.bus.port import BusPort

__all__ = ["Bus", "BusPort", "ListenerAnswer", "RowPacker", "ServiceError", "Subscription", "type_name"]
