"""Camera images recorded as ROS users record them: JPEG sensor_msgs/CompressedImage on .../image_rect_color/compressed
(raw Image with --raw-images), written on a writer thread, byte-identical for a seed, readable by rosbags and by
OpenCV's JPEG decoder (what cv_bridge / image_transport use) within JPEG error of the rendered frame."""

from __future__ import annotations

import subprocess
import sys
import threading
from pathlib import Path

import cv2
import numpy as np
import pytest
from rosbags.highlevel import AnyReader
from rosbags.typesys import Stores, get_typestore

from conftest import needs_gl
from racecar_sim import Simulator
from racecar_sim.drivers import ConstantCommand
from racecar_sim.msgs import Header, Image
from racecar_sim.recording.images import (
    compress_image,
    compressed_topic,
    decompress_image,
)
from racecar_sim.recording.run_recording import RunRecording
from racecar_sim.recording.writer_thread import WriterThread

IMAGE = "/camera/zed/rgb/image_rect_color"
COMPRESSED = IMAGE + "/compressed"
CLI = [sys.executable, "-m", "racecar_sim"]


def read(path: Path) -> tuple[dict[str, int], dict[str, str], list]:
    """Message counts and types per topic, and the deserialized messages of the compressed image topic."""
    with AnyReader([path], default_typestore=get_typestore(Stores.EMPTY)) as reader:
        counts = {c.topic: c.msgcount for c in reader.connections}
        types = {c.topic: c.msgtype for c in reader.connections}
        images = [c for c in reader.connections if c.topic == COMPRESSED]
        messages = [reader.deserialize(raw, c.msgtype) for c, _, raw in reader.messages(connections=images)]
    return counts, types, messages


def psnr(a: np.ndarray, b: np.ndarray) -> float:
    mse = np.mean((a.astype(float) - b.astype(float)) ** 2)
    return float(10 * np.log10(255.0**2 / mse))


@needs_gl
def test_compressed_images_round_trip_through_rosbags_to_the_rendered_frames(tmp_path):
    sim = Simulator(world="walker", seed=5)
    frames: list[tuple[int, np.ndarray]] = []
    sim.subscribe(
        IMAGE,
        lambda m: frames.append(
            (m.header.stamp.sec * 10**9 + m.header.stamp.nanosec, np.asarray(m.data).reshape(480, 640, 3).copy())
        ),
    )
    ConstantCommand(sim.bus, sim.scheduler, 1.0, 0.1)
    path = tmp_path / "run.mcap"
    with RunRecording(sim.bus, lambda: sim.time_ns, path, image_topics=[IMAGE]):
        sim.run_until(0.5)
    sim.close()
    counts, types, messages = read(path)
    assert IMAGE not in counts and types[COMPRESSED] == "sensor_msgs/msg/CompressedImage"
    assert counts[COMPRESSED] == len(frames) == 15 and counts["/scan"] == 20
    for msg, (stamp, rendered) in zip(messages, frames):
        assert msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec == stamp
        assert msg.header.frame_id == "camera_link" and msg.format == "bgr8; jpeg compressed bgr8"
        decoded = cv2.imdecode(np.frombuffer(bytes(msg.data), np.uint8), cv2.IMREAD_COLOR)  # BGR, as cv_bridge
        assert decoded.shape == rendered.shape
        assert np.abs(decoded.astype(int) - rendered.astype(int)).mean() < 3.0
        assert psnr(decoded, rendered) > 30.0
    assert rendered.std() > 10, "a scene, not a blank frame"


def test_jpeg_is_deterministic_and_decodes_in_both_encodings():
    rng = np.random.default_rng(1)
    y, x = np.mgrid[0:48, 0:64]
    bgr = np.stack([x * 4, y * 5, (x + y) * 2], axis=-1).astype(np.uint8)
    bgr = np.clip(bgr + rng.normal(0, 2, bgr.shape), 0, 255).astype(np.uint8)
    header = Header.at(1_500_000_000, "camera_link")
    as_bgr = Image(header, 48, 64, "bgr8", 0, 64 * 3, bgr.reshape(-1))
    as_rgb = Image(header, 48, 64, "rgb8", 0, 64 * 3, np.ascontiguousarray(bgr[..., ::-1]).reshape(-1))
    first, again = compress_image(as_bgr), compress_image(as_bgr)
    assert first.data == again.data and first.data[:2] == b"\xff\xd8"  # a JPEG file, the same bytes
    assert compress_image(as_rgb).format == "rgb8; jpeg compressed bgr8" and first.header is header
    for msg in (first, compress_image(as_rgb)):
        assert psnr(decompress_image(msg), bgr) > 30.0
        assert psnr(cv2.imdecode(np.frombuffer(msg.data, np.uint8), cv2.IMREAD_COLOR), bgr) > 30.0
    assert (
        compressed_topic("/car2/camera/zed/rgb/image_rect_color") == "/car2/camera/zed/rgb/image_rect_color/compressed"
    )
    with pytest.raises(ValueError, match="mono8"):
        compress_image(Image(header, 1, 1, "mono8", 0, 1, b"\x00"))


@needs_gl
def test_main_job_records_compressed_images_byte_identical_for_a_seed(tmp_path):
    paths = []
    for name in ("a", "b"):
        out = tmp_path / name
        result = subprocess.run(
            [*CLI, "run", "--duration", "1", "--seed", "3", "--out", str(out), "--no-summary"],
            check=False,
            capture_output=True,
            text=True,
            timeout=300,
        )
        assert result.returncode == 0, result.stderr
        paths.append(out / "run.mcap")
        assert (out / "camera.mp4").stat().st_size > 0
    assert paths[0].read_bytes() == paths[1].read_bytes()
    counts, types, messages = read(paths[0])
    assert counts[COMPRESSED] == 30 and IMAGE not in counts and counts["/scan"] == 40
    assert types[COMPRESSED] == "sensor_msgs/msg/CompressedImage"
    assert all(m.format == "bgr8; jpeg compressed bgr8" for m in messages)
    assert decompress_image(messages[-1]).std() > 10


@needs_gl
def test_raw_images_flag_records_the_raw_image(tmp_path):
    result = subprocess.run(
        [*CLI, "run", "--duration", "0.2", "--out", str(tmp_path), "--no-summary", "--no-video", "--raw-images"],
        check=False,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert result.returncode == 0, result.stderr
    counts, types, _ = read(tmp_path / "run.mcap")
    assert COMPRESSED not in counts and counts[IMAGE] == 6 and types[IMAGE] == "sensor_msgs/msg/Image"


def test_raw_images_without_a_recording_is_one_line():
    result = subprocess.run(
        [*CLI, "run", "--raw-images", "--no-record"], check=False, capture_output=True, text=True, timeout=120
    )
    assert result.returncode == 2 and "--raw-images" in result.stderr and "Traceback" not in result.stderr


def test_recording_is_finished_when_the_run_fails(tmp_path):
    sim = Simulator(world="empty", lidar=False, camera=False)
    path = tmp_path / "failed.mcap"
    with pytest.raises(RuntimeError, match="driver crashed"), RunRecording(sim.bus, lambda: sim.time_ns, path):
        sim.run_until(0.3)
        raise RuntimeError("driver crashed")
    sim.close()
    counts, _, _ = read(path)  # rosbags reads the summary and footer: the file is complete
    assert counts["/vesc/odom"] >= 5


def test_writer_thread_keeps_order_and_reports_errors():
    seen: list[int] = []
    names: set[str] = set()
    writer = WriterThread("test", depth=2)
    for i in range(100):
        writer.submit(lambda i=i: (seen.append(i), names.add(threading.current_thread().name)))
    writer.close()
    assert seen == list(range(100)) and names == {"test"}

    writer = WriterThread("failing")
    writer.submit(lambda: 1 / 0)
    writer.submit(lambda: seen.append(-1))  # may or may not be accepted before the error is seen
    with pytest.raises(ZeroDivisionError):
        for _ in range(10_000):
            writer.submit(lambda: seen.append(-1))
    writer.close()  # the error was raised once: close() finishes quietly
    assert -1 not in seen, "jobs after a failed one do not run"
    with pytest.raises(ValueError, match="after close"):
        writer.submit(lambda: None)
