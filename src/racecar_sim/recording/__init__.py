"""Recording of bus traffic to MCAP files (ROS 2 CDR, sim-time stamps; a run's written by a writer process, camera
images as JPEG), and recovery of killed recordings.

The names below are imported on first use (PEP 562), so that importing a module of this package loads only what that
module needs: the writer process's child starts reading its pipe (recording/hand_overs.py) before mcap and the
message classes are loaded.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

_LAZY = {
    "McapRecorder": "racecar_sim.recording.mcap_recorder",
    "RecordingFileError": "racecar_sim.recording.recording_file",
    "Recovery": "racecar_sim.recording.recover",
    "default_output": "racecar_sim.recording.recover",
    "recover_mcap": "racecar_sim.recording.recover",
    "RunRecording": "racecar_sim.recording.run_recording",
}

__all__ = ["McapRecorder", "RecordingFileError", "Recovery", "RunRecording", "default_output", "recover_mcap"]

if TYPE_CHECKING:
    from racecar_sim.recording.mcap_recorder import McapRecorder
    from racecar_sim.recording.recording_file import RecordingFileError
    from racecar_sim.recording.recover import Recovery, default_output, recover_mcap
    from racecar_sim.recording.run_recording import RunRecording


def __getattr__(name: str) -> Any:
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'racecar_sim.recording' has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted({*globals(), *_LAZY})
