"""camera.mp4 of a run: BGR camera frames streamed to an H.264 MP4, or to an animated GIF preview without FFmpeg.

Frames go to the file as they come (nothing is buffered beyond the encoder's lookahead, and the writer thread's
queue when encoding in the background), so a run that fails half-way still leaves a playable file once close()
runs, e.g. from a `finally` block.
"""

from __future__ import annotations

import functools
import logging
import math
from fractions import Fraction
from pathlib import Path
from types import TracebackType
from typing import Any, BinaryIO, Final

import numpy as np

from racecar_sim.recording.writer_thread import WriterThread

log = logging.getLogger("racecar_sim")

CODEC: Final = "libx264"
PIX_FMT = "yuv420p"  # what every player decodes; needs even width and height
# ultrafast: ~1.3 ms of CPU a 640x480 sim frame, 1-3 MB a minute; veryfast halves the size for three times the CPU.
# A constant quantiser (qp 23), not x264's default crf 23: crf rates each frame's complexity on a half-size copy
# first (x264's lowres lookahead), 0.6-0.9 ms of the 2-2.3 ms a frame took. On the main job's noisy frames qp 23
# decodes as close to the source as crf 23 did (luma PSNR 43.5 dB) in 8 % fewer bytes; on noise-free frames it
# gives 54.6 dB where crf 23 spent more bits for 60.6 dB (docs/recordings.md). One thread: the encoder runs beside
# the simulation and the camera, where x264's own threads only add synchronisation (~10 % of its CPU).
X264_OPTIONS = {"preset": "ultrafast", "qp": "23", "threads": "1"}
KEYFRAME_INTERVAL = 2.0  # s, so a player seeks within a 60 s run without decoding far
GIF_MAX_SIZE = (320, 240)  # px; the preview is downscaled to fit
GIF_MAX_FPS = 10.0
GIF_COLORS = 128


class VideoWriter:
    """Camera frames to an H.264 MP4 (PyAV / FFmpeg), or an animated GIF preview when no encoder is available.

    Frames are (height, width, 3) uint8 BGR, top row first (the camera's bgr8 image). `path` is the file actually
    written: its suffix becomes .gif when it fell back. `frames` counts the frames given to write(); the GIF keeps
    every step-th of them (at most GIF_MAX_FPS). No frame written, no file. Usable as a context manager;
    close() is idempotent.

    `background`: encode on a WriterThread, in order, while the caller goes on; write() then keeps a reference
    to the frame, which must not change afterwards, and an encoder error is raised by a later write() or close().
    """

    def __init__(self, path: str | Path, fps: float, width: int, height: int, background: bool = False) -> None:
        if not (fps > 0 and math.isfinite(fps)):
            raise ValueError(f"fps must be a positive number, got {fps}")
        if width <= 0 or height <= 0:
            raise ValueError(f"frame size must be positive, got {width}x{height}")
        self.fps, self.width, self.height = float(fps), int(width), int(height)
        self.frames = 0
        self._closed = False
        self._encoder: _Mp4Encoder | _GifEncoder
        reason = _h264_missing()
        if reason is None:
            self.path = Path(path)
            self._encoder = _Mp4Encoder(self.path, self.fps, self.width, self.height)
        else:
            self.path = Path(path).with_suffix(".gif")
            log.warning("no H.264 encoder (%s): writing an animated GIF preview, %s", reason, self.path)
            self._encoder = _GifEncoder(self.path, self.fps, self.width, self.height)
        self._thread = WriterThread(f"video {self.path}") if background else None

    @property
    def shape(self) -> tuple[int, int, int]:
        """The shape write() expects: (height, width, 3)."""
        return self.height, self.width, 3

    def write(self, frame_bgr: np.ndarray) -> None:
        """Append one frame; raises ValueError when it is not a (height, width, 3) uint8 array."""
        if self._closed:
            raise ValueError(f"write() after close() of {self.path}")
        frame = np.asarray(frame_bgr)
        if frame.shape != self.shape or frame.dtype != np.uint8:
            raise ValueError(f"expected a {self.shape} uint8 BGR frame, got {frame.shape} {frame.dtype}")
        if self._thread is None:
            self._encoder.write(frame, self.frames)
        else:
            self._thread.submit(functools.partial(self._encoder.write, frame, self.frames))
        self.frames += 1

    @property
    def takes_yuv420p(self) -> bool:
        """Whether write_yuv420p() can be used: not for the GIF preview, an odd width or height, a background
        encoder."""
        encoder = self._encoder
        return (
            self._thread is None
            and isinstance(encoder, _Mp4Encoder)
            and encoder.width == self.width
            and encoder.height == self.height
        )

    def yuv420p_frame(self) -> Any:
        """A new frame for write_yuv420p() to fill (PyAV's yuv420p VideoFrame of the video's size), or None where
        the video takes BGR frames only (takes_yuv420p)."""
        if not self.takes_yuv420p:
            return None
        assert isinstance(self._encoder, _Mp4Encoder)
        return self._encoder.frame_type(self.width, self.height, PIX_FMT)

    def write_yuv420p(self, frame: Any) -> None:
        """Append one frame made by yuv420p_frame() and filled with limited-range BT.601 planes (what write()
        would have converted its BGR frame to): the encoder takes it without a conversion."""
        if self._closed:
            raise ValueError(f"write() after close() of {self.path}")
        assert isinstance(self._encoder, _Mp4Encoder) and self._thread is None
        self._encoder.encode(frame, self.frames)
        self.frames += 1

    def close(self) -> Path:
        """Flush the encoder and finish the file (the MP4 index, the GIF trailer); returns the path written."""
        if not self._closed:
            self._closed = True
            try:
                if self._thread is not None:
                    self._thread.close()
            finally:
                self._encoder.close()
        return self.path

    def __enter__(self) -> VideoWriter:
        return self

    def __exit__(
        self, exc_type: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> None:
        self.close()


def _h264_missing() -> str | None:
    """Why no MP4 can be written (one line), or None when PyAV and its libx264 encoder are both there."""
    try:
        import av
    except ImportError as exc:
        return f"PyAV is not importable: {exc}"
    try:
        av.codec.Codec(CODEC, "w")
    except Exception as exc:  # UnknownCodecError, or an FFmpeg build without the encoder
        return f"PyAV {av.__version__} has no {CODEC} encoder: {exc}"
    return None


class _Mp4Encoder:
    """libx264 in an MP4 container; frame i is stamped i / fps."""

    def __init__(self, path: Path, fps: float, width: int, height: int) -> None:
        import av

        # yuv420p subsamples chroma 2x2: an odd last row or column is cropped off.
        self.width, self.height = width - width % 2, height - height % 2
        rate = Fraction(fps).limit_denominator(1001)  # 30 -> 30/1, 29.97 -> 2997/100
        self.container = av.open(str(path), mode="w")
        try:
            self.stream = self.container.add_stream(CODEC, rate=rate)
            self.stream.width, self.stream.height, self.stream.pix_fmt = self.width, self.height, PIX_FMT
            self.time_base = self.stream.time_base = 1 / rate  # the muxer later sets the stream's to its own
            self.stream.codec_context.gop_size = max(1, round(KEYFRAME_INTERVAL * fps))
            self.stream.options = dict(X264_OPTIONS)
        except BaseException:
            self.container.close()
            raise
        self.frame_type = av.VideoFrame
        # one converter for the whole file, on this thread: frame.reformat() makes a new one per frame, and with it
        # FFmpeg's scaler threads (started and joined per frame: ~2 ms of a frame's wall time for a 0.2 ms job)
        self._reformatter = av.video.reformatter.VideoReformatter()
        self._convert: dict[str, Any] = {"format": PIX_FMT, "threads": 1}

    def write(self, frame: np.ndarray, index: int) -> None:
        frame = np.ascontiguousarray(frame[: self.height, : self.width])
        video_frame = self.frame_type.from_numpy_buffer(frame, format="bgr24")  # wraps the pixels, no copy
        try:
            video_frame = self._reformatter.reformat(video_frame, **self._convert)
        except TypeError:  # a PyAV without reformat(threads=)
            if self._convert.pop("threads", None) is None:
                raise
            video_frame = self._reformatter.reformat(video_frame, **self._convert)
        self.encode(video_frame, index)

    def encode(self, video_frame: Any, index: int) -> None:
        """A yuv420p frame of the stream's size to the file."""
        video_frame.pts = index
        video_frame.time_base = self.time_base
        for packet in self.stream.encode(video_frame):
            self.container.mux(packet)

    def close(self) -> None:
        try:
            for packet in self.stream.encode(None):  # the frames still in x264's lookahead
                self.container.mux(packet)
        finally:
            self.container.close()  # writes the index (moov): without it the file does not play


class _GifEncoder:
    """Pillow, frame by frame: the header with the first kept frame, one block per frame, the trailer at close."""

    def __init__(self, path: Path, fps: float, width: int, height: int) -> None:
        self.step = max(1, math.ceil(fps / GIF_MAX_FPS))
        self.delay_ms = round(1000 * self.step / fps)
        scale = min(1.0, GIF_MAX_SIZE[0] / width, GIF_MAX_SIZE[1] / height)
        self.size = (max(1, round(width * scale)), max(1, round(height * scale)))
        self.path = path
        self.file: BinaryIO | None = None  # opened with the first frame, as the MP4 muxer does

    def write(self, frame: np.ndarray, index: int) -> None:
        if index % self.step:
            return
        from PIL import GifImagePlugin, Image

        image = Image.fromarray(np.ascontiguousarray(frame[..., ::-1]))  # BGR -> RGB
        if image.size != self.size:
            image = image.resize(self.size, Image.Resampling.BILINEAR)
        paletted = image.quantize(GIF_COLORS, method=Image.Quantize.FASTOCTREE, dither=Image.Dither.NONE)
        if self.file is None:
            header, _ = GifImagePlugin.getheader(paletted, info={"loop": 0, "duration": self.delay_ms})
            self.file = open(self.path, "wb")
            self.file.writelines(header)
        params: dict[str, Any] = {"duration": self.delay_ms, "include_color_table": True}
        self.file.writelines(GifImagePlugin.getdata(paletted, **params))
        self.file.flush()  # a killed run keeps every frame written so far

    def close(self) -> None:
        if self.file is not None:
            try:
                self.file.write(b";")  # GIF trailer
            finally:
                self.file.close()
