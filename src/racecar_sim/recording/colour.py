"""A camera frame's colour conversion done once in the writer process, for both the JPEG and the video.

Each bgr8 frame the writer process records is encoded twice: a JPEG for `<image topic>/compressed` and an x264
frame for camera.mp4. Each encoder converted the BGR pixels on its own: libjpeg-turbo to full-range YCbCr 4:2:0
(~0.3 ms of a 640x480 frame) and libswscale to limited-range yuv420p (~1 ms: FFmpeg's C loop for bgr24, without
SIMD). Here one compiled pass (colour_kernel.py, ~0.4 ms) makes the JPEG's planes exactly as libjpeg-turbo does,
so simplejpeg.encode_jpeg_yuv_planes gives encode_jpeg's bytes, and the video's from them (within a level or two
of swscale's); the video frame is filled in place and swscale is not run.

Frames the kernel does not cover (odd sizes, and for the JPEG widths not a multiple of 16; rgb8, padded rows, a
GIF video) and machines where the kernel does not load (no numba) go the encoders' own way, as before.
"""

from __future__ import annotations

import logging
import threading
from collections.abc import Callable
from typing import Any

import numpy as np

from racecar_sim.msgs import Image
from racecar_sim.msgs.sensor_msgs import CompressedImage
from racecar_sim.recording.images import JPEG_QUALITY, compress_image

log = logging.getLogger("racecar_sim")

JPEG_WIDTH_STEP = 16
"""The JPEG from planes is encode_jpeg's for any even height, but only for widths of whole 16-pixel MCUs: at a
ragged right edge libjpeg-turbo replicates the last full-resolution column before downsampling, and the planes'
encoder pads the downsampled planes."""


_loading = threading.Lock()  # one load at a time: the writer's start and a video opened meanwhile wait for one
_loaded: list[Callable[..., None] | None] = []


def load_kernel() -> Callable[..., None] | None:
    """The compiled conversion (numba's cached kernel, loaded the light way), or None where it cannot load; loaded
    once per process."""
    with _loading:
        if not _loaded:
            _loaded.append(_load())
        return _loaded[0]


def _load() -> Callable[..., None] | None:
    try:
        from racecar_sim.core.compiled import load_numba

        load_numba()
        from racecar_sim.recording.colour_kernel import bgr_to_planes

        pixels, luma, chroma = np.zeros((2, 6), np.uint8), np.zeros((2, 2), np.uint8), np.zeros((1, 1), np.uint8)
        bgr_to_planes(pixels, luma, chroma, chroma, True, luma, chroma, chroma)  # its machine code linked in now
    except Exception as exc:  # no numba, or a broken cache: the encoders convert, as before
        log.debug("writer: no compiled colour conversion (%s); the encoders convert each frame", exc)
        return None
    return bgr_to_planes


class CameraPlanes:
    """The last camera image's planes: the JPEG's (reused buffers) and, when a video takes them, its yuv420p frame.

    jpeg(msg) and video_frame(msg) convert `msg` at the first of the two calls for it (the same Image object) and
    reuse the result at the second. Both return None where the fast path does not cover the image (or the kernel
    could not load): the caller then encodes it as before. Made, the kernel is loaded (load_kernel: waited for where
    the writer's start is still loading it)."""

    def __init__(self) -> None:
        self._kernel = load_kernel()
        self._image: Image | None = None
        self._jpeg_planes: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None
        self._frame: Any = None  # the video's yuv420p frame of _image, until the video takes it

    def jpeg(self, msg: Image, video: Any, quality: int = JPEG_QUALITY) -> bytes | None:
        """`msg`'s JPEG: simplejpeg.encode_jpeg's bytes of its pixels; None where not covered. `video`: the open
        VideoWriter (or None), whose frame of `msg` is made in the same pass."""
        if msg.width % JPEG_WIDTH_STEP or not self._convert(msg, video):
            return None
        import simplejpeg

        assert self._jpeg_planes is not None
        return simplejpeg.encode_jpeg_yuv_planes(*self._jpeg_planes, quality=quality)

    def compressed(self, msg: Image, video: Any, quality: int = JPEG_QUALITY) -> Any:
        """`msg` as compress_image() makes it (the same header, format and bytes)."""
        jpeg = self.jpeg(msg, video, quality)
        if jpeg is None:
            return compress_image(msg, quality)
        return CompressedImage(msg.header, f"{msg.encoding}; jpeg compressed bgr8", jpeg)

    def video_frame(self, msg: Image, video: Any) -> Any:
        """`msg` as `video`'s yuv420p frame (a PyAV VideoFrame, given once); None where not covered."""
        if not self._convert(msg, video):
            return None
        frame, self._frame = self._frame, None
        return frame

    def _convert(self, msg: Image, video: Any) -> bool:
        if msg is self._image:
            return True
        self._image, self._frame = None, None
        if msg.encoding != "bgr8" or msg.height % 2 or msg.width % 2 or msg.step != 3 * msg.width:
            return False
        if self._kernel is None:  # no numba here
            return False
        height, width = msg.height, msg.width
        rows = np.frombuffer(msg.data, np.uint8, height * msg.step).reshape(height, msg.step)
        if self._jpeg_planes is None or self._jpeg_planes[0].shape != (height, width):
            half = (height // 2, width // 2)
            self._jpeg_planes = (
                np.empty((height, width), np.uint8),
                np.empty(half, np.uint8),
                np.empty(half, np.uint8),
            )
        frame = video.yuv420p_frame() if video is not None and video.shape == (height, width, 3) else None
        planes = frame_planes(frame) if frame is not None else self._jpeg_planes
        self._kernel(rows, *self._jpeg_planes, frame is not None, *planes)
        self._image, self._frame = msg, frame
        return True


def frame_planes(frame: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A yuv420p VideoFrame's Y, U and V planes as writable arrays of its size (rows a line size apart)."""
    return tuple(  # type: ignore[return-value]
        np.frombuffer(plane, np.uint8).reshape(-1, plane.line_size)[: plane.height, : plane.width]
        for plane in frame.planes
    )
