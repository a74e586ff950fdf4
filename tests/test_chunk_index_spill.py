"""A long recording's memory stays flat: the MCAP writer's chunk indexes (one per chunk, a dict of the chunk's
channels, kept for the summary) wait in a temporary file, not in memory, and the file written is byte for byte the
one keeping them in memory gives, readable by rosbags."""

from __future__ import annotations

import hashlib
import tracemalloc

from rosbags.highlevel import AnyReader

from racecar_sim.msgs import String, serialize
from racecar_sim.recording import mcap_recorder
from racecar_sim.recording.mcap_recorder import CHUNK_DURATION_NS, McapRecorder

CHANNELS = 40  # topics in every chunk (a 4-car run has about 90)
DATA = serialize(String("x"))


def record(path, chunks: int, grown: list[float] | None = None) -> str:
    """`chunks` chunks of one message per channel (each its own sim second: a chunk each); the file's sha256.
    `grown`: gets the memory (MB) allocated while writing the second half and not freed."""
    recorder = McapRecorder(path)
    for k in range(chunks):
        if grown is not None and k == chunks // 2:
            tracemalloc.start()
            before = tracemalloc.get_traced_memory()[0]
        for c in range(CHANNELS):
            recorder.write_serialized(f"/topic{c}", "std_msgs/msg/String", DATA, k * CHUNK_DURATION_NS + c)
    if grown is not None:
        grown.append((tracemalloc.get_traced_memory()[0] - before) / 2**20)
        tracemalloc.stop()
    recorder.close()
    return hashlib.sha256(path.read_bytes()).hexdigest()


def test_a_long_recording_keeps_its_chunk_indexes_out_of_memory(tmp_path):
    grown: list[float] = []
    record(tmp_path / "long.mcap", 1200, grown)
    assert grown[0] < 0.2, f"{grown[0]:.2f} MB kept for 600 chunks"  # in memory: 600 x 3 KB = 1.8 MB
    assert [p.name for p in tmp_path.iterdir()] == ["long.mcap"]  # the temporary file is gone
    with AnyReader([tmp_path / "long.mcap"]) as reader:
        assert sum(1 for _ in reader.messages()) == 1200 * CHANNELS


def test_the_file_is_the_one_the_list_in_memory_gives(tmp_path, monkeypatch):
    spilled = record(tmp_path / "spilled.mcap", 50)
    monkeypatch.setattr(mcap_recorder, "spill_chunk_indexes", lambda *args: None)
    assert record(tmp_path / "listed.mcap", 50) == spilled
