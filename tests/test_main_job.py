"""The main job: `racecar-sim run` with no arguments (here shortened by --duration) leaves runs/<time>/ with the
MCAP (camera images as JPEG CompressedImage), summary.png and camera.mp4, and prints the summary."""

from __future__ import annotations

import io
import subprocess
import sys

import av
import numpy as np
from PIL import Image
from rosbags.highlevel import AnyReader
from rosbags.typesys import Stores, get_typestore


def test_run_with_no_arguments_writes_the_run_folder(tmp_path):
    result = subprocess.run(
        [sys.executable, "-m", "racecar_sim", "run", "--duration", "4"],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert result.returncode == 0, result.stderr
    (folder,) = (tmp_path / "runs").iterdir()
    out = result.stdout
    assert out.startswith("world walker, driver wall-follow"), out
    for label in ("distance", "mean speed", "real-time factor", "min clearance"):
        assert f"\n{label}" in out, out
    for name in ("summary.png", "run.mcap", "camera.mp4"):
        assert f"wrote            runs/{folder.name}/{name}" in out, out
    distance = float(next(line for line in out.splitlines() if line.startswith("distance")).split()[1])
    assert 3.0 < distance < 4.0 * 2.5  # it drove, no faster than the driver's top speed

    with Image.open(folder / "summary.png") as png:
        assert png.format == "PNG" and png.size == (1600, 1000)
        pixels = np.asarray(png.convert("RGB"))
    assert len(np.unique(pixels.reshape(-1, 3), axis=0)) > 500  # a map, a path, a camera frame: not blank

    with AnyReader([folder / "run.mcap"], default_typestore=get_typestore(Stores.EMPTY)) as reader:
        counts = {c.topic: c.msgcount for c in reader.connections}
        # camera images as ROS users record them: JPEG CompressedImage on .../compressed (raw with --raw-images)
        assert counts["/scan"] == 160 and counts["/camera/zed/rgb/image_rect_color/compressed"] == 120
        assert "/camera/zed/rgb/image_rect_color" not in counts
        assert counts["/vesc/odom"] == 80 and counts["/vesc/ackermann_cmd_mux/input/navigation"] == 160
        images = [c for c in reader.connections if c.topic == "/camera/zed/rgb/image_rect_color/compressed"]
        connection, _, raw = next(reader.messages(connections=images))
        image = reader.deserialize(raw, connection.msgtype)
        assert connection.msgtype == "sensor_msgs/msg/CompressedImage"
        assert image.format == "bgr8; jpeg compressed bgr8"
        with Image.open(io.BytesIO(bytes(image.data))) as jpeg:
            assert jpeg.format == "JPEG" and jpeg.size == (640, 480)

    with av.open(str(folder / "camera.mp4")) as video:
        stream = video.streams.video[0]
        frames = [f.to_ndarray(format="bgr24") for f in video.decode(stream)]
    assert len(frames) == 120 and frames[0].shape == (480, 640, 3)
    assert frames[-1].std() > 10  # the racecourse, not a blank frame
