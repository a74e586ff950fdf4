"""VideoWriter: an H.264 MP4 that decodes back to the frames written, the GIF fallback, bad frames."""

from __future__ import annotations

import logging
import sys

import av
import numpy as np
import pytest
from PIL import Image

from racecar_sim.recording import video
from racecar_sim.recording.video import VideoWriter

WIDTH, HEIGHT, FPS, FRAMES = 640, 480, 30.0, 60
SQUARE, STEP, TOP = 64, 8, 100  # px: side, move per frame, top row
RED_BGR = (0, 0, 255)
BACKGROUND = 40


def moving_square(i: int, width: int = WIDTH, height: int = HEIGHT) -> np.ndarray:
    """Frame i: a red square STEP*i px from the left edge on a dark grey background."""
    frame = np.full((height, width, 3), BACKGROUND, np.uint8)
    frame[TOP : TOP + SQUARE, STEP * i : STEP * i + SQUARE] = RED_BGR
    return frame


def red_centroid(bgr: np.ndarray) -> np.ndarray:
    """(x, y) centre of the pixels that are clearly red."""
    b, g, r = (bgr[..., c].astype(int) for c in range(3))
    rows, cols = np.nonzero((r > 150) & (g < 100) & (b < 100))
    return np.array([cols.mean(), rows.mean()])


def test_mp4_decodes_to_the_frames_written(tmp_path):
    with VideoWriter(tmp_path / "camera.mp4", FPS, WIDTH, HEIGHT) as writer:
        for i in range(FRAMES):
            writer.write(moving_square(i))
    assert writer.path == tmp_path / "camera.mp4"
    assert writer.frames == FRAMES

    with av.open(str(writer.path)) as container:
        stream = container.streams.video[0]
        assert stream.codec_context.name == "h264"
        assert float(stream.duration * stream.time_base) == pytest.approx(FRAMES / FPS, abs=1e-3)
        decoded = list(container.decode(stream))
    assert len(decoded) == FRAMES
    assert (decoded[0].width, decoded[0].height) == (WIDTH, HEIGHT)
    assert [f.time for f in decoded] == pytest.approx([i / FPS for i in range(FRAMES)], abs=1e-3)
    for i in (0, 17, FRAMES - 1):
        bgr = decoded[i].to_ndarray(format="bgr24")
        centre = (STEP * i + SQUARE / 2 - 0.5, TOP + SQUARE / 2 - 0.5)
        assert red_centroid(bgr) == pytest.approx(centre, abs=1.0)
        inside = bgr[int(centre[1]), int(centre[0])].astype(int)
        assert np.abs(inside - RED_BGR).max() < 40  # yuv420p and H.264 quantisation
        assert np.abs(bgr[HEIGHT - 20, 20].astype(int) - BACKGROUND).max() < 10


def test_close_in_finally_after_a_crash_leaves_a_playable_file(tmp_path):
    writer = VideoWriter(tmp_path / "camera.mp4", FPS, WIDTH, HEIGHT)
    with pytest.raises(RuntimeError):
        try:
            for i in range(FRAMES):
                if i == 10:
                    raise RuntimeError("the run failed")
                writer.write(moving_square(i))
        finally:
            writer.close()
    assert writer.close() == writer.path  # idempotent
    with av.open(str(writer.path)) as container:
        assert sum(1 for _ in container.decode(video=0)) == 10


def test_odd_frame_size_is_cropped_to_even(tmp_path):
    with VideoWriter(tmp_path / "odd.mp4", FPS, 321, 241) as writer:
        for i in range(5):
            writer.write(moving_square(i, 321, 241))
    with av.open(str(writer.path)) as container:
        frame = next(container.decode(video=0))
    assert (frame.width, frame.height) == (320, 240)


def test_wrong_frame_names_expected_and_actual_shape(tmp_path):
    with VideoWriter(tmp_path / "camera.mp4", FPS, WIDTH, HEIGHT) as writer:
        with pytest.raises(ValueError, match=r"\(480, 640, 3\).*\(480, 641, 3\)"):
            writer.write(np.zeros((480, 641, 3), np.uint8))
        with pytest.raises(ValueError, match=r"\(480, 640, 3\) uint8.*\(480, 640\) uint8"):
            writer.write(np.zeros((480, 640), np.uint8))
        with pytest.raises(ValueError, match="float32"):
            writer.write(np.zeros((480, 640, 3), np.float32))
        assert writer.frames == 0
    with pytest.raises(ValueError, match="after close"):
        writer.write(moving_square(0))


def _no_libx264(name: str, mode: str = "r") -> None:
    raise av.codec.codec.UnknownCodecError(name)


@pytest.mark.parametrize("breakage", ["no av", "no libx264"])
def test_gif_fallback_without_an_encoder(tmp_path, monkeypatch, caplog, breakage):
    if breakage == "no av":
        monkeypatch.setitem(sys.modules, "av", None)  # `import av` raises ImportError
    else:
        monkeypatch.setattr(av.codec, "Codec", _no_libx264)
    with caplog.at_level(logging.WARNING, logger="racecar_sim"):
        writer = VideoWriter(tmp_path / "camera.mp4", FPS, WIDTH, HEIGHT)
    with writer:
        for i in range(FRAMES):
            writer.write(moving_square(i))
    assert writer.path == tmp_path / "camera.gif"
    assert not (tmp_path / "camera.mp4").exists()
    assert len([r for r in caplog.records if "GIF" in r.getMessage()]) == 1

    step = 3  # 30 fps -> every third frame, 10 fps
    with Image.open(writer.path) as gif:
        assert gif.format == "GIF"
        assert gif.size == (video.GIF_MAX_SIZE[0], video.GIF_MAX_SIZE[1])
        assert gif.n_frames == FRAMES // step
        assert gif.info["duration"] == 100
        gif.seek(5)  # input frame 15, at half size
        rgb = np.asarray(gif.convert("RGB"))
    centre = red_centroid(rgb[..., ::-1])
    assert centre == pytest.approx(((STEP * 5 * step + SQUARE / 2) / 2, (TOP + SQUARE / 2) / 2), abs=1.0)
