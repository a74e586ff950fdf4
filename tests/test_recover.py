"""Crash safety of recordings: chunks closed every second of sim time, and `racecar-sim recover` for a killed run."""

from __future__ import annotations

import os
import signal
import stat
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest
from mcap.reader import make_reader
from mcap.stream_reader import StreamReader
from mcap.writer import Writer
from rosbags.highlevel import AnyReader
from rosbags.typesys import Stores, get_typestore

from racecar_sim import Simulator, msgs
from racecar_sim.core.errors import RacecarSimError
from racecar_sim.drivers import ConstantCommand
from racecar_sim.recording import McapRecorder, recover_mcap

CLI = [sys.executable, "-m", "racecar_sim"]
NS = 1_000_000_000
KILL_AT = 12.5  # s of sim time at which the recording process is killed
STEP = 0.0025  # s, the default physics step: the finest grain of log times

# Records a constant-command drive to argv[1], runs to argv[2] s of sim time, says so, then waits to be killed.
RECORD_THEN_WAIT = textwrap.dedent("""
    import sys, time
    from racecar_sim import Simulator
    from racecar_sim.drivers import ConstantCommand
    sim = Simulator(world="empty", camera=False, seed=3)
    ConstantCommand(sim.bus, sim.scheduler, 1.0, 0.2)
    sim.record(sys.argv[1])
    sim.run_until(float(sys.argv[2]))
    print("ready", flush=True)
    time.sleep(600)
""")

Row = tuple[str, int, bytes]  # topic, log time, payload


def record_and_kill(path: Path, at: float = KILL_AT) -> None:
    """A recording process stopped by SIGKILL at sim time `at`: no close(), no footer."""
    proc = subprocess.Popen(
        [sys.executable, "-c", RECORD_THEN_WAIT, str(path), str(at)], stdout=subprocess.PIPE, text=True
    )
    try:
        assert proc.stdout is not None and proc.stdout.readline().strip() == "ready"
    finally:
        os.kill(proc.pid, signal.SIGKILL)
        proc.wait(timeout=30)
    assert proc.returncode == -signal.SIGKILL


def intact_rows(path: Path) -> tuple[list[Row], bool]:
    """The messages a streaming reader gets from `path` in file order, and whether the file ends before a footer (a
    record cut in the middle, or a file that stops between two records: a kill while the writer was idle).

    Independent of racecar_sim.recording.recover: mcap's own StreamReader, stopped by the truncated tail.
    """
    topics: dict[int, str] = {}
    rows: list[Row] = []
    footer = False
    with path.open("rb") as f:
        try:
            for record in StreamReader(f, validate_crcs=True).records:
                kind = type(record).__name__
                if kind == "Channel":
                    topics[record.id] = record.topic
                elif kind == "Message":
                    rows.append((topics[record.channel_id], record.log_time, record.data))
                footer = kind == "Footer"
        except Exception:  # whatever the cut makes the reader raise
            return rows, True
    return rows, not footer


def rosbags_rows(path: Path) -> list[Row]:
    with AnyReader([path], default_typestore=get_typestore(Stores.EMPTY)) as reader:
        return [(c.topic, t, raw) for c, t, raw in reader.messages()]


def mcap_rows(path: Path) -> list[Row]:
    """Messages in file order, read through the summary (fails on a file without one)."""
    with path.open("rb") as f:
        reader = make_reader(f)
        assert reader.get_summary() is not None
        return [(c.topic, m.log_time, m.data) for _, c, m in reader.iter_messages(log_time_order=False)]


def recover_cli(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([*CLI, "recover", *args], capture_output=True, text=True, timeout=120)


def by_log_time(rows: list[Row]) -> list[Row]:
    return sorted(rows, key=lambda row: row[1])  # stable: ties keep file order


def count(rows: list[Row], topic: str) -> int:
    return sum(1 for row in rows if row[0] == topic)


def record(path: Path, duration: float, seed: int = 3) -> None:
    with Simulator(world="empty", camera=False, seed=seed) as sim:
        ConstantCommand(sim.bus, sim.scheduler, 1.0, 0.2)
        sim.record(path)
        sim.run_until(duration)


def test_sigkill_mid_run_is_recovered_with_every_message_of_the_complete_chunks(tmp_path: Path) -> None:
    broken = tmp_path / "killed.mcap"
    record_and_kill(broken)

    # The problem: no footer, so the readers that start from the summary refuse the file.
    with pytest.raises(Exception):  # noqa: B017  # rosbags: "File end magic is invalid."
        rosbags_rows(broken)
    with pytest.raises(Exception), broken.open("rb") as f:  # noqa: B017
        list(make_reader(f).iter_messages())
    expected, cut = intact_rows(broken)
    assert cut, "the killed file must end without a footer"
    assert len(expected) > 5000

    result = recover_cli(str(broken))
    assert result.returncode == 0, result.stderr
    fixed = tmp_path / "killed.recovered.mcap"  # the default output, beside the input
    line = result.stdout.strip()
    assert "\n" not in line and line.startswith(str(fixed))
    channels = len({row[0] for row in expected})  # every topic the run recorded before the kill
    assert f"{len(expected)} messages on {channels} channels" in line and "log time 0.000 s to" in line

    recovered = rosbags_rows(fixed)
    assert sorted(recovered) == sorted(expected)  # every intact message, nothing else
    assert mcap_rows(fixed) == by_log_time(expected)  # written in log-time order, ties in recorded order
    times = [t for _, t, _ in recovered]
    assert times == sorted(times)

    # The open chunk is all that was lost: less than a second of sim time before the kill.
    last = times[-1] / NS
    assert last == max(t for _, t, _ in expected) / NS
    assert KILL_AT - 1.0 - STEP < last <= KILL_AT
    assert f"to {last:.3f} s;" in line
    # Every topic is complete up to there: counts follow the publishers' rates.
    for topic, rate in (("/scan", 40), ("/clock", 100), ("/vesc/odom", 20), ("/racecar/joint_states", 50)):
        assert abs(count(recovered, topic) - rate * last) <= 1, topic
    assert count(recovered, "/tf_static") == 1

    # Same profile, schemas and channel metadata (/tf_static stays transient-local).
    with fixed.open("rb") as f:
        reader = make_reader(f)
        assert reader.get_header().profile == "ros2"
        summary = reader.get_summary()
        assert summary is not None
        qos = {c.topic: c.metadata["offered_qos_profiles"] for c in summary.channels.values()}
        assert "durability: 1" in qos["/tf_static"] and "durability: 2" in qos["/scan"]
        assert {s.encoding for s in summary.schemas.values()} == {"ros2msg"}
        assert [m.name for m in reader.iter_metadata()] == ["rosbag2"]


def test_cli_run_killed_while_writing_is_recovered(tmp_path: Path) -> None:
    """`racecar-sim run` killed at an arbitrary moment, possibly in the middle of writing a chunk."""
    broken, fixed = tmp_path / "run.mcap", tmp_path / "fixed.mcap"
    proc = subprocess.Popen(
        [
            *CLI,
            "run",
            "--world",
            "empty",
            "--driver",
            "constant",
            "--no-camera",
            "--duration",
            "3000",
            "--record",
            str(broken),
            "--out",
            str(tmp_path),
            "--no-summary",
        ],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    try:
        deadline = time.time() + 120
        while (
            time.time() < deadline and proc.poll() is None and (not broken.exists() or broken.stat().st_size < 150_000)
        ):
            time.sleep(0.01)
    finally:
        os.kill(proc.pid, signal.SIGKILL)
        proc.wait(timeout=30)
    assert proc.returncode == -signal.SIGKILL  # killed mid-run, not finished
    expected, cut = intact_rows(broken)
    assert cut and len(expected) > 1000

    result = recover_cli(str(broken), "-o", str(fixed))
    assert result.returncode == 0, result.stderr
    assert result.stdout.startswith(f"{fixed}: {len(expected)} messages")
    assert sorted(rosbags_rows(fixed)) == sorted(expected)
    assert not (tmp_path / "run.recovered.mcap").exists()


def test_a_cut_through_a_chunk_loses_that_chunk_and_says_how_many_bytes(tmp_path: Path) -> None:
    complete, broken = tmp_path / "complete.mcap", tmp_path / "cut.mcap"
    record(complete, 4.0)
    with complete.open("rb") as f:
        summary = make_reader(f).get_summary()
    assert summary is not None
    last_chunk = max(summary.chunk_indexes, key=lambda c: c.chunk_start_offset)
    cut_at = last_chunk.chunk_start_offset + last_chunk.chunk_length // 2
    broken.write_bytes(complete.read_bytes()[:cut_at])

    result = recover_mcap(broken)
    assert result.output == tmp_path / "cut.recovered.mcap"
    assert not result.complete
    assert result.lost_bytes == cut_at - last_chunk.chunk_start_offset
    original = mcap_rows(complete)
    kept = [row for row in original if row[1] < last_chunk.message_start_time]
    assert result.messages == len(kept) and result.end_ns == kept[-1][1]
    assert sorted(rosbags_rows(result.output)) == sorted(kept)
    line = result.summary()
    assert f"the last {result.lost_bytes} bytes of {broken} could not be read" in line
    assert f"a truncated Chunk record at byte {last_chunk.chunk_start_offset}" in line


def test_chunks_close_every_second_of_sim_time(tmp_path: Path) -> None:
    path = tmp_path / "five.mcap"
    seconds = 5
    record(path, seconds)
    with path.open("rb") as f:
        summary = make_reader(f).get_summary()
    assert summary is not None
    chunks = sorted(summary.chunk_indexes, key=lambda c: c.chunk_start_offset)
    assert len(chunks) >= seconds
    assert all(c.message_end_time - c.message_start_time < NS for c in chunks)
    assert all(a.message_end_time < b.message_start_time for a, b in zip(chunks, chunks[1:]))
    assert {c.compression for c in chunks} == {"zstd"}


def test_same_seed_recordings_are_byte_identical(tmp_path: Path) -> None:
    first, second = tmp_path / "a.mcap", tmp_path / "b.mcap"
    record(first, 3.0, seed=7)
    record(second, 3.0, seed=7)
    assert first.read_bytes() == second.read_bytes()


def test_complete_file_is_rewritten_with_the_same_messages(tmp_path: Path) -> None:
    original, copy = tmp_path / "whole.mcap", tmp_path / "copy.mcap"
    record(original, 2.0)
    result = recover_cli(str(original), "-o", str(copy))
    assert result.returncode == 0, result.stderr
    assert result.stdout.strip().endswith(f"{original} was complete")
    rows = mcap_rows(original)
    assert mcap_rows(copy) == by_log_time(rows)
    assert sorted(rosbags_rows(copy)) == sorted(rows)
    with original.open("rb") as a, copy.open("rb") as b:
        sa, sb = make_reader(a).get_summary(), make_reader(b).get_summary()
        assert sa is not None and sb is not None
        assert [(c.topic, c.message_encoding, c.metadata) for c in sa.channels.values()] == [
            (c.topic, c.message_encoding, c.metadata) for c in sb.channels.values()
        ]
        assert [(s.name, s.data) for s in sa.schemas.values()] == [(s.name, s.data) for s in sb.schemas.values()]
    # In place: the output replaces the input only once it is complete.
    again = recover_mcap(copy, copy)
    assert again.complete and mcap_rows(copy) == by_log_time(rows)


def test_messages_out_of_log_time_order_come_out_sorted(tmp_path: Path) -> None:
    path = tmp_path / "unordered.mcap"
    times = [0, 1_500_000_000, 500_000_000, 2_600_000_000, 2_000_000_000, 500_000_000]
    with McapRecorder(path) as rec:
        for i, t in enumerate(times):
            rec.write("/n", msgs.Int8(i), t)
    result = recover_mcap(path, tmp_path / "sorted.mcap")
    rows = mcap_rows(result.output)
    assert [t for _, t, _ in rows] == sorted(times)
    assert [row[2] for row in rows] == [row[2] for row in by_log_time(mcap_rows(path))]


def test_loose_messages_of_an_unchunked_file_are_recovered(tmp_path: Path) -> None:
    path = tmp_path / "loose.mcap"
    with path.open("wb") as f:
        writer = Writer(f, use_chunking=False)
        writer.start(profile="ros2")
        schema = writer.register_schema("std_msgs/msg/Int8", "ros2msg", b"int8 data")
        channel = writer.register_channel("/n", "cdr", schema)
        for i in range(10):
            writer.add_message(channel, i * NS, bytes([0, 1, 0, 0, i]), i * NS)
        writer.finish()
    data = path.read_bytes()
    message_size = 9 + 2 + 4 + 8 + 8 + 5
    last = data.rindex(bytes([0, 1, 0, 0, 9])) + 5 - message_size  # the tenth message record
    path.write_bytes(data[: last + 20])
    result = recover_mcap(path)
    assert (result.messages, result.channels, result.lost_bytes) == (9, 1, 20)
    assert [t for _, t, _ in rosbags_rows(result.output)] == [i * NS for i in range(9)]


@pytest.mark.parametrize("kind", ["missing", "text", "directory", "empty"])
def test_recover_rejects_what_is_not_mcap_in_one_line(tmp_path: Path, kind: str) -> None:
    target = tmp_path / f"{kind}.mcap"
    if kind == "text":
        target.write_text("hello, not a recording\n")
    elif kind == "directory":
        target.mkdir()
    elif kind == "empty":
        target.touch()
    result = recover_cli(str(target))
    assert result.returncode == 2
    assert "Traceback" not in result.stderr and result.stdout == ""
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"racecar-sim: error: {target}")
    assert not list(tmp_path.glob("*.recovered.mcap"))


def test_recover_to_an_unwritable_place_is_one_line(tmp_path: Path) -> None:
    source = tmp_path / "ok.mcap"
    McapRecorder(source).close()
    result = recover_cli(str(source), "-o", "/proc/recovered.mcap")
    assert result.returncode == 2 and "Traceback" not in result.stderr
    assert result.stderr.strip().splitlines() == [
        "racecar-sim: error: /proc/recovered.mcap: cannot write the recovered file (No such file or directory)"
    ]


def test_recorder_rejects_a_directory_or_unwritable_folder_in_one_line(tmp_path: Path) -> None:
    for target in (tmp_path, Path("/proc/foo.mcap"), tmp_path / "missing" / "run.mcap"):
        with pytest.raises(RacecarSimError) as info:
            McapRecorder(target)
        message = str(info.value)
        assert "\n" not in message and message.startswith(f"{target}: cannot create the MCAP file")
        assert isinstance(info.value, OSError)  # and still the OSError open() raised
    assert isinstance(_error(tmp_path), IsADirectoryError)


@pytest.mark.skipif(os.name != "posix" or os.geteuid() == 0, reason="root writes into read-only folders")
def test_recorder_in_a_read_only_folder_is_one_line(tmp_path: Path) -> None:
    folder = tmp_path / "ro"
    folder.mkdir()
    folder.chmod(stat.S_IRUSR | stat.S_IXUSR)
    try:
        error = _error(folder / "run.mcap")
        assert isinstance(error, PermissionError)
        assert str(error) == f"{folder / 'run.mcap'}: cannot create the MCAP file (Permission denied)"
    finally:
        folder.chmod(stat.S_IRWXU)


def _error(path: Path) -> RacecarSimError:
    with pytest.raises(RacecarSimError) as info:
        McapRecorder(path)
    return info.value
