"""The in-process topic bus: the spine every node publishes to and subscribes from, with ROS-style services."""

from racecar_sim.bus.bus import Bus, ServiceError, Subscription

__all__ = ["Bus", "ServiceError", "Subscription"]
