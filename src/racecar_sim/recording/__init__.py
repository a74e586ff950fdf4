"""Recording of bus traffic to MCAP files (ROS 2 CDR, sim-time stamps), and recovery of killed recordings."""

from racecar_sim.recording.mcap_recorder import McapRecorder, RecordingFileError
from racecar_sim.recording.recover import Recovery, default_output, recover_mcap

__all__ = ["McapRecorder", "RecordingFileError", "Recovery", "default_output", "recover_mcap"]
