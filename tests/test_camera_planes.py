"""The writer process's colour conversion (recording/colour.py): a camera frame converted once, into the JPEG's planes
(simplejpeg.encode_jpeg_yuv_planes must give exactly encode_jpeg's bytes of the BGR pixels: libjpeg-turbo's own
conversion is the expectation) and the video's yuv420p frame (within two levels of libswscale's bgr24 -> yuv420p).
Frames the fast path does not cover, and a writer without the kernel, give compress_image's bytes."""

from __future__ import annotations

from pathlib import Path

import av
import numpy as np
import pytest
import simplejpeg

from conftest import needs_gl
from racecar_sim.msgs import Header, Image
from racecar_sim.recording import colour
from racecar_sim.recording.colour import CameraPlanes
from racecar_sim.recording.images import compress_image
from racecar_sim.recording.video import VideoWriter

SUMMARY_PNG = Path(__file__).parents[1] / "docs" / "images" / "summary.png"


def image(bgr: np.ndarray, encoding: str = "bgr8", pad: int = 0) -> Image:
    height, width = bgr.shape[:2]
    rows = np.zeros((height, width * 3 + pad), np.uint8)
    rows[:, : width * 3] = bgr.reshape(height, -1)
    return Image(Header(), height, width, encoding, 0, width * 3 + pad, rows.tobytes())


def random_frame(height: int, width: int, seed: int = 0) -> np.ndarray:
    return np.random.default_rng(seed).integers(0, 256, (height, width, 3), dtype=np.uint8)


def picture(height: int = 480, width: int = 640) -> np.ndarray:
    """A real picture's pixels (the docs' run summary: plots, text, a camera inset), BGR."""
    from PIL import Image as PilImage

    with PilImage.open(SUMMARY_PNG) as png:
        rgb = np.asarray(png.convert("RGB"))
    assert rgb.shape[0] >= height and rgb.shape[1] >= width
    return np.ascontiguousarray(rgb[:height, :width, ::-1])


def expected_jpeg(bgr: np.ndarray, quality: int = 80) -> bytes:
    return simplejpeg.encode_jpeg(bgr, quality=quality, colorspace="BGR", colorsubsampling="420")


def swscale_planes(bgr: np.ndarray) -> list[np.ndarray]:
    """libswscale's yuv420p of a BGR frame, as the video encoded it before (one thread, PyAV's default filter)."""
    frame = av.video.reformatter.VideoReformatter().reformat(
        av.VideoFrame.from_ndarray(np.ascontiguousarray(bgr), format="bgr24"), format="yuv420p"
    )
    return [np.array(plane) for plane in colour.frame_planes(frame)]


def test_the_kernel_loads():
    assert colour.load_kernel() is not None  # numba is a dependency: the fast path is what the tests below check


@pytest.mark.parametrize(
    "frame",
    [random_frame(480, 640), random_frame(2, 16, 1), random_frame(6, 32, 2), random_frame(38, 48, 3), picture()],
    ids=["random 640x480", "16x2", "32x6", "48x38", "picture"],
)
@pytest.mark.parametrize("quality", [80, 95])
def test_the_jpeg_is_encode_jpegs_bytes(frame, quality):
    planes = CameraPlanes()
    jpeg = planes.jpeg(image(frame), None, quality)
    assert jpeg is not None and jpeg == expected_jpeg(frame, quality)


def test_extreme_colours_give_the_same_jpeg():
    """The corners of the colour cube, where the fixed point's rounding and the bias decide the last bit."""
    corners = np.array([[b, g, r] for b in (0, 255) for g in (0, 255) for r in (0, 1, 254, 255)], np.uint8)
    frame = np.resize(corners, (64, 96, 3)).astype(np.uint8)
    frame[::3] = frame[::3, ::-1]
    assert CameraPlanes().jpeg(image(frame), None) == expected_jpeg(frame)


@pytest.mark.parametrize(
    "msg",
    [
        image(random_frame(35, 50), "bgr8"),  # odd height
        image(random_frame(36, 49), "bgr8"),  # odd width
        image(random_frame(36, 50), "bgr8"),  # a width of 16-pixel blocks and a bit
        image(random_frame(36, 48), "rgb8"),
        image(random_frame(36, 48), "bgr8", pad=6),  # padded rows
    ],
    ids=["odd height", "odd width", "width 50", "rgb8", "padded rows"],
)
def test_frames_the_fast_path_does_not_cover_are_compressed_as_before(msg):
    planes = CameraPlanes()
    assert planes.jpeg(msg, None) is None
    assert planes.compressed(msg, None).data == compress_image(msg).data


def test_without_the_kernel_images_are_compressed_as_before(monkeypatch):
    monkeypatch.setattr(colour, "load_kernel", lambda: None)
    msg = image(random_frame(48, 64))
    planes = CameraPlanes()
    assert planes.jpeg(msg, None) is None
    compressed = planes.compressed(msg, None)
    assert (compressed.data, compressed.format) == (compress_image(msg).data, compress_image(msg).format)


@pytest.mark.parametrize("frame", [random_frame(480, 640, 4), picture()], ids=["random", "picture"])
def test_the_video_planes_are_swscales_within_two_levels(frame, tmp_path):
    with VideoWriter(tmp_path / "camera.mp4", 30.0, frame.shape[1], frame.shape[0]) as video:
        planes = CameraPlanes()
        msg = image(frame)
        jpeg = planes.jpeg(msg, video)  # the JPEG first, as the writer process gets them: one pass makes both
        video_frame = planes.video_frame(msg, video)
        assert jpeg == expected_jpeg(frame)
        assert video_frame is not None and planes.video_frame(msg, video) is None  # given once
        ours = [np.array(plane, dtype=int) for plane in colour.frame_planes(video_frame)]
        video.write_yuv420p(video_frame)
    luma, *chroma = (np.abs(mine - theirs) for mine, theirs in zip(ours, swscale_planes(frame)))
    assert luma.max() == 0  # swscale's own fixed point
    for difference in chroma:  # 2x2 means of the JPEG's chroma; swscale filters rows and puts grey at 127
        assert difference.max() <= 2 and difference.mean() < 1.0
    assert 16 <= ours[0].min() and ours[0].max() <= 235  # limited range
    assert 16 <= min(p.min() for p in ours[1:]) and max(p.max() for p in ours[1:]) <= 240


def test_greys_are_bt601_limited_range(tmp_path):
    """Neutral greys: chroma 128, luma 16 + 219/255 of the level (swscale's truncated 15-bit fixed point: a level
    below at most)."""
    levels = np.repeat(np.arange(256, dtype=np.uint8), 2)[None, :].repeat(2, axis=0)  # 2x512: each level a 2x2 block
    frame = np.repeat(levels[..., None], 3, axis=2)
    with VideoWriter(tmp_path / "grey.mp4", 30.0, 512, 2) as video:
        video_frame = CameraPlanes().video_frame(image(frame), video)
        y, u, v = (np.array(plane, dtype=int) for plane in colour.frame_planes(video_frame))
        video.write_yuv420p(video_frame)
    below = 16 + np.arange(256) * 219 / 255 - y[0, ::2]
    assert (below >= 0).all() and (below <= 1).all() and y.min() == 16
    assert (u == 128).all() and (v == 128).all()


def test_a_video_from_planes_decodes_as_the_bgr_video_does(tmp_path):
    """camera.mp4 written from the planes and from BGR frames (libswscale): the same frame count, size, pixel format,
    and decoded pictures within x264's error of each other."""
    frames = [np.roll(picture(240, 320), 4 * i, axis=1) for i in range(8)]
    paths = {}
    for way in ("planes", "bgr"):
        with VideoWriter(tmp_path / f"{way}.mp4", 30.0, 320, 240) as video:
            planes = CameraPlanes()
            for frame in frames:
                if way == "bgr":
                    video.write(frame)
                else:
                    video.write_yuv420p(planes.video_frame(image(frame), video))
        paths[way] = video.path
    decoded = {}
    for way, path in paths.items():
        with av.open(str(path)) as container:
            stream = container.streams.video[0]
            assert (stream.codec_context.name, stream.codec_context.pix_fmt) == ("h264", "yuv420p")
            decoded[way] = [f.to_ndarray(format="bgr24").astype(int) for f in container.decode(stream)]
    assert len(decoded["planes"]) == len(decoded["bgr"]) == len(frames)
    for mine, theirs, frame in zip(decoded["planes"], decoded["bgr"], frames):
        assert mine.shape == frame.shape
        assert np.abs(mine - theirs).mean() < 2.0
        assert np.abs(mine - frame).mean() < 6.0  # a picture of the frame, not just like the other video


def test_a_gif_or_odd_sized_video_takes_bgr_frames(tmp_path):
    with VideoWriter(tmp_path / "odd.mp4", 30.0, 49, 36) as video:
        msg = image(random_frame(36, 49))
        assert not video.takes_yuv420p and video.yuv420p_frame() is None
        assert CameraPlanes().video_frame(msg, video) is None
        video.write(msg.bgr_pixels())


@needs_gl
def test_a_rendered_camera_frame_gives_the_same_jpeg():
    from racecar_sim import Simulator

    sim = Simulator(world="walker", seed=5)
    frames: list[Image] = []
    sim.subscribe("/camera/zed/rgb/image_rect_color", frames.append)
    sim.run_until(0.1)
    sim.close()
    msg = frames[-1]
    pixels = msg.bgr_pixels()
    assert pixels.std() > 10, "a scene, not a blank frame"
    assert CameraPlanes().jpeg(msg, None) == compress_image(msg).data == expected_jpeg(np.ascontiguousarray(pixels))
    assert CameraPlanes().compressed(msg, None).data == compress_image(msg).data
