"""The in-process topic bus: the spine every node publishes to and subscribes from."""

from racecar_sim.bus.bus import Bus, Subscription

__all__ = ["Bus", "Subscription"]
