"""Recording of bus traffic to MCAP files (ROS 2 CDR, sim-time stamps; a run's written by a writer process, camera
images as JPEG), and recovery of killed recordings."""

from racecar_sim.recording.mcap_recorder import McapRecorder, RecordingFileError
from racecar_sim.recording.recover import Recovery, default_output, recover_mcap
from racecar_sim.recording.run_recording import RunRecording

__all__ = ["McapRecorder", "RecordingFileError", "Recovery", "RunRecording", "default_output", "recover_mcap"]
