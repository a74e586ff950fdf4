"""Both sensors on, recorded: the MCAP holds every scan and image, byte for byte, and rosbags reads it."""

from __future__ import annotations

import numpy as np
import pytest
from rosbags.highlevel import AnyReader
from rosbags.typesys import Stores, get_typestore

from racecar_sim import Simulator
from racecar_sim.drivers import ConstantCommand

IMAGE = "/camera/zed/rgb/image_rect_color"
INFO = "/camera/zed/rgb/camera_info"


def test_ten_seconds_with_lidar_and_camera_record_intact(tmp_path):
    sim = Simulator(world="walker", seed=3)
    if sim.car.camera is None:
        pytest.skip("no OpenGL (EGL or OSMesa) here; .ci/run installs Mesa")
    images: list[bytes] = []
    scans: list[np.ndarray] = []
    sim.subscribe(IMAGE, lambda msg: images.append(bytes(msg.data)))
    sim.subscribe("/scan", lambda msg: scans.append(np.asarray(msg.ranges).copy()))
    ConstantCommand(sim.bus, sim.scheduler, 1.0, 0.0)
    path = tmp_path / "sensors.mcap"
    sim.record(path)
    sim.run_until(10.0)
    sim.close()
    assert len(images) == 300 and len(scans) == 400
    with AnyReader([path], default_typestore=get_typestore(Stores.EMPTY)) as reader:
        counts = {c.topic: c.msgcount for c in reader.connections}
        types = {c.topic: c.msgtype for c in reader.connections}
        assert counts[IMAGE] == 300 and counts[INFO] == 300 and counts["/scan"] == 400
        assert types[IMAGE] == "sensor_msgs/msg/Image" and types["/scan"] == "sensor_msgs/msg/LaserScan"
        image_connections = [c for c in reader.connections if c.topic == IMAGE]
        for i, (connection, _, raw) in enumerate(reader.messages(connections=image_connections)):
            msg = reader.deserialize(raw, connection.msgtype)
            assert (msg.width, msg.height, msg.encoding) == (640, 480, "bgr8")
            assert bytes(msg.data) == images[i], f"image {i} changed on its way to the file"
        scan_connections = [c for c in reader.connections if c.topic == "/scan"]
        for i, (connection, _, raw) in enumerate(reader.messages(connections=scan_connections)):
            ranges = reader.deserialize(raw, connection.msgtype).ranges
            np.testing.assert_array_equal(ranges, scans[i].astype(np.float32))
