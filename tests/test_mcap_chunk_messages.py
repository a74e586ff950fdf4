"""Messages put straight into the MCAP writer's chunk (recording/chunk_messages.py) give the file mcap's own
Writer.add_message gives, byte for byte, and a file mcap reads back whole."""

from __future__ import annotations

import io
from pathlib import Path

import pytest
import zstandard
from mcap.reader import make_reader
from mcap.records import Chunk
from mcap.stream_reader import StreamReader
from mcap.writer import CompressionType, Writer

from racecar_sim.msgs import Float64, Header, JointControllerState, String, serialize
from racecar_sim.recording import mcap_recorder
from racecar_sim.recording.chunk_compression import compress_chunks
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


def _plain_writer_file(path: Path, messages: list[tuple[str, str, bytes, int]], level: int | None) -> bytes:
    """`messages` through mcap's own Writer.add_message, its chunks compressed by mcap (level None) or at `level`."""
    with open(path, "wb") as stream:
        writer = Writer(stream, chunk_size=4096, compression=CompressionType.ZSTD)
        if level is not None:
            assert compress_chunks(writer, level)
        writer.start(profile="ros2", library="test")
        channels: dict[str, int] = {}
        for topic, msgtype, data, t in messages:
            if topic not in channels:
                schema = writer.register_schema(msgtype, "ros2msg", b"")
                channels[topic] = writer.register_channel(topic, "cdr", schema)
            writer.add_message(channels[topic], t, data, t)
        writer.finish()
    return path.read_bytes()


def test_chunks_compressed_at_mcaps_level_are_mcaps_file(tmp_path: Path) -> None:
    """The chunk finalizer is mcap's: at mcap's own level (3) the file is the one mcap writes, byte for byte."""
    messages = _messages()
    assert _plain_writer_file(tmp_path / "ours.mcap", messages, 3) == _plain_writer_file(
        tmp_path / "mcap.mcap", messages, None
    )


def test_recording_chunks_at_level_1_hold_the_same_messages(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """A recording's chunks are zstd at level 1: each decompresses to the chunk level 3 would have compressed, and
    mcap's reader reads the file back whole."""
    messages = _messages()
    files = {}
    for level in (1, 3):
        monkeypatch.setattr(mcap_recorder, "compress_chunks", lambda writer, at=level: compress_chunks(writer, at))
        files[level] = tmp_path / f"level{level}.mcap"
        with McapRecorder(files[level], chunk_size=4096) as recorder:
            recorder.write_many(messages)

    def chunks(path: Path) -> list[tuple[bytes, bytes]]:
        records = StreamReader(io.BytesIO(path.read_bytes()), emit_chunks=True).records
        return [(r.data, zstandard.decompress(r.data)) for r in records if isinstance(r, Chunk)]

    level1, level3 = chunks(files[1]), chunks(files[3])
    assert len(level1) > 3 and [raw for _, raw in level1] == [raw for _, raw in level3]
    assert [data for data, _ in level1] == [zstandard.ZstdCompressor(level=1).compress(raw) for _, raw in level1]
    assert [data for data, _ in level3] == [zstandard.compress(raw) for _, raw in level3]  # mcap's own
    with open(files[1], "rb") as stream:
        reader = make_reader(stream)
        assert {c.compression for c in reader.get_summary().chunk_indexes} == {"zstd"}  # type: ignore[union-attr]
        read = [(c.topic, m.data, m.log_time) for _, c, m in reader.iter_messages(log_time_order=False)]
    assert read == [(topic, data, t) for topic, _, data, t in messages]


def test_a_writer_not_compressing_with_zstd_is_left_alone(tmp_path: Path) -> None:
    with open(tmp_path / "a.mcap", "wb") as stream:
        assert not compress_chunks(Writer(stream, compression=CompressionType.NONE))
        assert not compress_chunks(Writer(stream, use_chunking=False))


def test_a_batch_going_back_in_time_after_a_full_chunk(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """A chunk filled and closed inside one write_many by its latest message, then messages stamped before that one:
    the new chunk's end time is its own messages' latest (as add_message keeps it), not the closed chunk's."""
    monkeypatch.setattr(mcap_recorder, "_library", lambda: "racecar-sim test")
    topic, msgtype, data = "/car1/command", "std_msgs/msg/Float64", serialize(Float64(1.0))
    rising = [(topic, msgtype, data, 1_000_000 * step) for step in range(1, 300)]
    with McapRecorder(tmp_path / "probe.mcap", compression="none", chunk_size=4096) as recorder:
        recorder.write_many(rising)
    with open(tmp_path / "probe.mcap", "rb") as stream:
        summary = make_reader(stream).get_summary()
    assert summary is not None
    full = summary.chunk_indexes[0].message_end_time  # the message that fills the first chunk
    back = [(topic, msgtype, data, full - 50_000_000 + step) for step in range(5)]  # after it, stamped before it
    messages = [m for m in rising if m[3] <= full] + back
    files = {}
    for fast in (False, True):
        path = tmp_path / f"{fast}.mcap"
        with McapRecorder(path, compression="none", chunk_size=4096) as recorder:
            if fast:
                recorder.write_many(messages)
            else:
                recorder._chunk_messages = None
                for topic_, msgtype_, data_, t in messages:
                    recorder.write_serialized(topic_, msgtype_, data_, t)
        files[fast] = path.read_bytes()
    with open(tmp_path / "True.mcap", "rb") as stream:
        summary = make_reader(stream).get_summary()
    assert summary is not None and [c.message_end_time for c in summary.chunk_indexes] == [full, back[-1][3]]
    assert files[True] == files[False]
