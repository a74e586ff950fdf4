"""Camera images as ROS users record them: sensor_msgs/CompressedImage (JPEG) on `<image topic>/compressed`.

What image_transport's compressed plugin publishes: `format` is "<encoding>; jpeg compressed bgr8" and `data` a
JPEG file whose colours decode the usual way (RGB). Encoding is deterministic: libjpeg-turbo through Pillow at
a fixed quality gives the same bytes for the same pixels.
"""

from __future__ import annotations

import io

import numpy as np

from racecar_sim.msgs import Image
from racecar_sim.msgs.sensor_msgs import CompressedImage

COMPRESSED_SUFFIX = "/compressed"
JPEG_QUALITY = 80  # compressed_image_transport's default jpeg_quality
# the Pillow raw mode that reads each encoding's bytes as RGB
RAW_MODES = {"bgr8": "BGR", "rgb8": "RGB"}


def compressed_topic(image_topic: str) -> str:
    """Where image_transport publishes an image topic's JPEGs: /camera/image -> /camera/image/compressed."""
    return image_topic.rstrip("/") + COMPRESSED_SUFFIX


def compress_image(msg: Image, quality: int = JPEG_QUALITY) -> CompressedImage:
    """`msg` (bgr8 or rgb8) as a JPEG CompressedImage with the same header."""
    from PIL import Image as PilImage  # Pillow loads only when images are compressed

    raw_mode = RAW_MODES.get(msg.encoding)
    if raw_mode is None:
        raise ValueError(f"cannot JPEG-compress a {msg.encoding!r} image (only {', '.join(RAW_MODES)})")
    picture = PilImage.frombuffer("RGB", (msg.width, msg.height), msg.data, "raw", raw_mode, msg.step, 1)
    out = io.BytesIO()
    picture.save(out, "JPEG", quality=quality)
    return CompressedImage(msg.header, f"{msg.encoding}; jpeg compressed bgr8", out.getvalue())


def decompress_image(msg: CompressedImage) -> np.ndarray:
    """A CompressedImage's pixels: (height, width, 3) uint8 in BGR order, as image_transport decodes it to bgr8."""
    from PIL import Image as PilImage

    with PilImage.open(io.BytesIO(bytes(msg.data))) as picture:
        rgb = np.asarray(picture.convert("RGB"))
    return np.ascontiguousarray(rgb[..., ::-1])
