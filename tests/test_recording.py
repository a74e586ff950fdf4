"""McapRecorder: files that rosbags and the mcap reader read back, latched QoS, interruption."""

from __future__ import annotations

import io
import os
import signal
import subprocess
import sys
import textwrap
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from mcap.reader import make_reader
from rosbags.highlevel import AnyReader
from rosbags.interfaces import (
    Qos,
    QosDurability,
    QosHistory,
    QosLiveliness,
    QosReliability,
    QosTime,
)
from rosbags.rosbag2.metadata import dump_qos_v8
from rosbags.typesys import Stores, get_typestore

from racecar_sim import msgs
from racecar_sim.recording import McapRecorder

SCAN_TIMES = [0, 25_000_000, 50_000_000, 75_000_000]


def _scan(stamp_ns: int, rng: np.random.Generator) -> msgs.LaserScan:
    return msgs.LaserScan(
        header=msgs.Header.at(stamp_ns, "laser"),
        angle_min=-2.25,
        angle_max=2.25,
        range_min=0.1,
        range_max=10.0,
        ranges=rng.uniform(0.1, 10.0, 1081).astype(np.float32),
    )


def _tf_static() -> msgs.TFMessage:
    return msgs.TFMessage(
        [
            msgs.TransformStamped(
                msgs.Header.at(0, "base_link"),
                child,
                msgs.Transform(msgs.Vector3(x, 0.0, z)),
            )
            for child, x, z in (("laser", 0.265, 0.155), ("camera_link", 0.39, 0.2))
        ]
    )


def _read_all(path: Path) -> tuple[dict[str, str], list[tuple[str, int, Any]]]:
    with AnyReader([path], default_typestore=get_typestore(Stores.EMPTY)) as reader:
        types = {c.topic: c.msgtype for c in reader.connections}
        rows = [(c.topic, t, reader.deserialize(raw, c.msgtype)) for c, t, raw in reader.messages()]
    return types, rows


def test_round_trip_through_rosbags(tmp_path: Path) -> None:
    path = tmp_path / "run.mcap"
    rng = np.random.default_rng(0)
    scans = [_scan(t, rng) for t in SCAN_TIMES]
    pixels = rng.integers(0, 256, 480 * 640 * 3, dtype=np.uint8).tobytes()
    image = msgs.Image(msgs.Header.at(33_000_000, "camera"), 480, 640, "bgr8", 0, 1920, pixels)
    odom = msgs.Odometry(msgs.Header.at(20_000_000, "odom"), "base_link")
    odom.pose.pose.position.x = 1.25
    odom.twist.covariance[0] = 0.5
    drive = msgs.AckermannDriveStamped(msgs.Header.at(10_000_000, ""), msgs.AckermannDrive(0.25, speed=2.0))
    with McapRecorder(path) as rec:
        rec.write("/tf_static", _tf_static(), 0)
        for stamp, scan in zip(SCAN_TIMES, scans, strict=True):
            rec.write("/scan", scan, stamp)
        rec.write("/vesc/ackermann_cmd_mux/input/teleop", drive, 10_000_000, 9_000_000)
        rec.write("/vesc/odom", odom, 20_000_000)
        rec.write("/camera/zed/rgb/image_rect_color", image, 33_000_000)
        assert rec.message_count["/scan"] == 4

    types, rows = _read_all(path)
    assert types == {
        "/tf_static": "tf2_msgs/msg/TFMessage",
        "/scan": "sensor_msgs/msg/LaserScan",
        "/vesc/ackermann_cmd_mux/input/teleop": "ackermann_msgs/msg/AckermannDriveStamped",
        "/vesc/odom": "nav_msgs/msg/Odometry",
        "/camera/zed/rgb/image_rect_color": "sensor_msgs/msg/Image",
    }
    by_topic: dict[str, list[tuple[int, Any]]] = {}
    for topic, log_time, msg in rows:
        by_topic.setdefault(topic, []).append((log_time, msg))
    assert {t: len(v) for t, v in by_topic.items()} == rec.message_count
    assert [t for t, _ in by_topic["/scan"]] == SCAN_TIMES
    for (_, got), sent in zip(by_topic["/scan"], scans, strict=True):
        assert got.header.stamp.nanosec == sent.header.stamp.nanosec
        np.testing.assert_array_equal(got.ranges, sent.ranges)
    ((_, tf),) = by_topic["/tf_static"]
    assert [t.child_frame_id for t in tf.transforms] == ["laser", "camera_link"]
    assert tf.transforms[0].transform.translation.x == 0.265
    ((_, got_drive),) = by_topic["/vesc/ackermann_cmd_mux/input/teleop"]
    assert (got_drive.drive.steering_angle, got_drive.drive.speed) == (0.25, 2.0)
    ((_, got_odom),) = by_topic["/vesc/odom"]
    assert got_odom.child_frame_id == "base_link"
    assert got_odom.pose.pose.position.x == 1.25
    assert got_odom.pose.pose.orientation.w == 1.0
    assert got_odom.twist.covariance[0] == 0.5
    ((_, got_image),) = by_topic["/camera/zed/rgb/image_rect_color"]
    assert (got_image.height, got_image.width, got_image.encoding) == (480, 640, "bgr8")
    assert got_image.data.tobytes() == pixels


def test_log_and_publish_times_in_mcap(tmp_path: Path) -> None:
    path = tmp_path / "times.mcap"
    with McapRecorder(path, compression="none") as rec:
        rec.write("/clock", msgs.Clock(msgs.Time(1, 0)), 1_000_000_000, 999_000_000)
        rec.write("/clock", msgs.Clock(msgs.Time(2, 0)), 2_000_000_000)
    with path.open("rb") as f:
        reader = make_reader(f)
        assert reader.get_header().profile == "ros2"
        found = [(m.log_time, m.publish_time, m.sequence) for _, _, m in reader.iter_messages()]
        schema = next(iter(reader.get_summary().schemas.values()))  # type: ignore[union-attr]
    assert found == [(1_000_000_000, 999_000_000, 1), (2_000_000_000, 2_000_000_000, 2)]
    assert schema.encoding == "ros2msg"
    assert schema.data.decode() == msgs.schema_text("rosgraph_msgs/msg/Clock")


@pytest.mark.parametrize("error", [RuntimeError, KeyboardInterrupt])
def test_exception_inside_with_leaves_readable_file(tmp_path: Path, error: type) -> None:
    path = tmp_path / "interrupted.mcap"
    rng = np.random.default_rng(1)

    def record_then_fail() -> None:
        with McapRecorder(path) as rec:
            for stamp in SCAN_TIMES:
                rec.write("/scan", _scan(stamp, rng), stamp)
            raise error("stop")

    with pytest.raises(error):
        record_then_fail()
    types, rows = _read_all(path)
    assert types == {"/scan": "sensor_msgs/msg/LaserScan"}
    assert [t for _, t, _ in rows] == SCAN_TIMES


def test_sigint_during_write_is_deferred_until_the_file_is_consistent(tmp_path: Path) -> None:
    # a shell's background job starts with SIGINT ignored; this test needs Python's own handler
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        _interrupt_mid_write(tmp_path / "sigint.mcap")
    finally:
        signal.signal(signal.SIGINT, previous)


def _interrupt_mid_write(path: Path) -> None:
    rng = np.random.default_rng(2)
    rec = McapRecorder(path, chunk_size=1)
    rec.write("/scan", _scan(0, rng), 0)
    # what adds the message to the private writer (its chunk, or mcap's add_message), to signal mid-write
    owner = rec._chunk_messages if rec._chunk_messages is not None else rec._writer
    name = "add" if rec._chunk_messages is not None else "add_message"
    add_message = getattr(owner, name)

    def interrupted_add_message(*args: Any, **kwargs: Any) -> Any:
        os.kill(os.getpid(), signal.SIGINT)
        return add_message(*args, **kwargs)

    setattr(owner, name, interrupted_add_message)
    with pytest.raises(KeyboardInterrupt):
        rec.write("/scan", _scan(1, rng), 1)
    rec.close()
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler
    _, rows = _read_all(path)
    assert [t for _, t, _ in rows] == [0, 1]
    assert rec.message_count == {"/scan": 2}


def test_tf_static_declares_transient_local(tmp_path: Path) -> None:
    path = tmp_path / "qos.mcap"
    with McapRecorder(path) as rec:
        rec.write("/tf_static", _tf_static(), 0)
        rec.write("/tf", _tf_static(), 0)
    with path.open("rb") as f:
        summary = make_reader(f).get_summary()
    assert summary is not None
    metadata = {c.topic: c.metadata for c in summary.channels.values()}
    zero = QosTime(0, 0)
    latched = Qos(QosHistory.KEEP_LAST, 1, QosReliability.RELIABLE, QosDurability.TRANSIENT_LOCAL,
                  zero, zero, QosLiveliness.AUTOMATIC, zero, False)  # fmt: skip
    assert metadata["/tf_static"]["offered_qos_profiles"] == dump_qos_v8([latched])

    with AnyReader([path], default_typestore=get_typestore(Stores.EMPTY)) as reader:
        qos = {c.topic: c.ext.offered_qos_profiles for c in reader.connections}  # type: ignore[union-attr]
    assert [q.durability for q in qos["/tf_static"]] == [QosDurability.TRANSIENT_LOCAL]
    assert [q.durability for q in qos["/tf"]] == [QosDurability.VOLATILE]


def test_rosbag2_metadata_record_selects_integer_qos_form(tmp_path: Path) -> None:
    path = tmp_path / "meta.mcap"
    McapRecorder(path).close()
    with path.open("rb") as f:
        records = list(make_reader(f).iter_metadata())
    assert [(r.name, set(r.metadata)) for r in records] == [("rosbag2", {"ROS_DISTRO"})]


def test_sigkill_leaves_completed_chunks_for_a_streaming_reader(tmp_path: Path) -> None:
    path = tmp_path / "killed.mcap"
    script = f"""
        import os, signal
        import numpy as np
        from racecar_sim import msgs
        from racecar_sim.recording import McapRecorder
        rec = McapRecorder({str(path)!r}, chunk_size=20_000)
        for i in range(23):
            scan = msgs.LaserScan(ranges=np.full(1081, i, dtype=np.float32))
            rec.write("/scan", scan, i)
        os.kill(os.getpid(), signal.SIGKILL)
    """
    result = subprocess.run([sys.executable, "-c", textwrap.dedent(script)], check=False)
    assert result.returncode == -signal.SIGKILL

    class NonSeekable(io.RawIOBase):
        def __init__(self, data: bytes) -> None:
            self._data = io.BytesIO(data)

        def readable(self) -> bool:
            return True

        def readinto(self, buffer: Any) -> int:
            return self._data.readinto(buffer)

    stream = io.BufferedReader(NonSeekable(path.read_bytes()))
    times: list[int] = []

    def read_all() -> None:
        for _, _, message in make_reader(stream).iter_messages(log_time_order=False):
            times.append(message.log_time)

    with pytest.raises(Exception):  # noqa: B017  # the file ends without a footer
        read_all()
    # Five 4.4 kB scans exceed a 20 kB chunk: four chunks were complete, the fifth was lost.
    assert times == list(range(20))


def test_topic_with_two_types_is_rejected(tmp_path: Path) -> None:
    with McapRecorder(tmp_path / "types.mcap") as rec:
        rec.write("/cmd", msgs.Float64(1.0), 0)
        with pytest.raises(ValueError, match="'/cmd' is recorded as std_msgs/msg/Float64"):
            rec.write("/cmd", msgs.Int8(1), 1)


def test_bad_arguments(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match="compression"):
        McapRecorder(tmp_path / "x.mcap", compression="gzip")
    rec = McapRecorder(tmp_path / "y.mcap")
    with pytest.raises(ValueError, match="log_time_ns"):
        rec.write("/clock", msgs.Clock(), -1)
    with pytest.raises(TypeError, match="log_time_ns"):
        rec.write("/clock", msgs.Clock(), 0.5)  # type: ignore[arg-type]
    with pytest.raises(TypeError, match=r"field 'clock\.sec'"):
        rec.write("/clock", msgs.Clock(msgs.Time("soon")), 0)  # type: ignore[arg-type]
    rec.close()
    rec.close()  # idempotent
    with pytest.raises(ValueError, match="closed"):
        rec.write("/clock", msgs.Clock(), 0)
    assert rec.message_count == {}


def test_unwritable_path_names_the_path(tmp_path: Path) -> None:
    target = tmp_path / "missing" / "run.mcap"
    with pytest.raises(OSError, match=r"missing/run\.mcap") as info:
        McapRecorder(target)
    assert isinstance(info.value, FileNotFoundError)
    assert "\n" not in str(info.value)
