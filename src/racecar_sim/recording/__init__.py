"""Recording of bus traffic to MCAP files (ROS 2 CDR, sim-time stamps)."""

from racecar_sim.recording.mcap_recorder import McapRecorder

__all__ = ["McapRecorder"]
