"""Messages put straight into the MCAP writer's chunk (recording/chunk_messages.py) give the file mcap's own
Writer.add_message gives, byte for byte, and a file mcap reads back whole."""

from __future__ import annotations

from pathlib import Path

import pytest
from mcap.reader import make_reader

from racecar_sim.msgs import Float64, Header, JointControllerState, String, serialize
from racecar_sim.recording import mcap_recorder
from racecar_sim.recording.chunk_messages import ChunkMessages
from racecar_sim.recording.mcap_recorder import McapRecorder

STATE = "control_msgs/msg/JointControllerState"


def _messages() -> list[tuple[str, str, bytes, int]]:
    """Three topics of three types over 2.5 sim s, a log time that goes back, data of varied lengths: chunks close
    by size (a small chunk_size) and by time (every sim second)."""
    out = []
    for step in range(250):
        t = step * 10_000_000
        state = JointControllerState(Header.at(t, "base_link"), set_point=step * 0.5, command=-step / 3.0)
        out.append(("/car1/racecar/left_rear/state", STATE, serialize(state), t))
        if step % 3 == 0:
            out.append(("/car1/command", "std_msgs/msg/Float64", serialize(Float64(step / 7.0)), t))
        if step % 50 == 7:
            text = String("x" * (step % 13) + "é")
            out.append(("/note", "std_msgs/msg/String", serialize(text), max(0, t - 5_000_000)))  # back in time
    return out


def _record(
    path: Path, messages: list[tuple[str, str, bytes, int]], compression: str, fast: bool, batch: bool
) -> bytes:
    with McapRecorder(path, compression=compression, chunk_size=4096) as recorder:
        if not fast:
            recorder._chunk_messages = None  # mcap's Writer.add_message, message by message
        else:
            assert recorder._chunk_messages is not None, "mcap's Writer is not the one ChunkMessages knows"
        if batch:
            recorder.write_many(messages[:100])
            recorder.write_many(messages[100:])
        else:
            for topic, msgtype, data, t in messages:
                recorder.write_serialized(topic, msgtype, data, t)
        counts = recorder.message_count
    assert sum(counts.values()) == len(messages)
    return path.read_bytes()


@pytest.mark.parametrize("compression", ["zstd", "none"])
def test_same_bytes_as_add_message(tmp_path: Path, compression: str, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(mcap_recorder, "_library", lambda: "racecar-sim test")
    messages = _messages()
    files = {}
    for fast in (False, True):
        for batch in (False, True):
            files[fast, batch] = _record(tmp_path / f"{fast}-{batch}.mcap", messages, compression, fast, batch)
    reference = files[False, False]
    assert all(data == reference for data in files.values())
    with open(tmp_path / "True-True.mcap", "rb") as stream:
        reader = make_reader(stream)
        summary = reader.get_summary()
        assert summary is not None and len(summary.chunk_indexes) > 3  # chunks closed by size and by time
        read = [(c.topic, m.data, m.log_time, m.sequence) for _, c, m in reader.iter_messages(log_time_order=False)]
    assert [(topic, data, t) for topic, data, t, _ in read] == [(t, d, n) for t, _, d, n in messages]
    assert [n for topic, _, _, n in read if topic == "/car1/command"] == list(range(1, 85))


def test_unknown_writer_falls_back(tmp_path: Path) -> None:
    """A writer without mcap 1.6.0's private state (another version) is written through add_message."""

    class Other:
        pass

    assert ChunkMessages.of(Other()) is None  # type: ignore[arg-type]
    with McapRecorder(tmp_path / "a.mcap") as recorder:
        assert recorder._chunk_messages is not None
