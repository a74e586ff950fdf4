"""Opening the images a world is made of (occupancy maps, albedo maps) with their size checked before any decoding.

PIL reads only the header on open; the pixels are decoded on load. A map of 20000 x 20000 cells would take gigabytes
(and PIL refuses to open one, as a decompression bomb), so the size is checked against MAX_IMAGE_PIXELS first.
"""

from __future__ import annotations

import re
import struct
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

from racecar_sim.core.errors import WorldError

if TYPE_CHECKING:  # PIL (~10 ms) is imported by the first world that has an image, not by every run
    from PIL import Image

MAX_IMAGE_SIDE = 8192  # the largest map is MAX_IMAGE_SIDE x MAX_IMAGE_SIDE cells, or any shape of as many
MAX_IMAGE_PIXELS = MAX_IMAGE_SIDE * MAX_IMAGE_SIDE  # 67 million: half a gigabyte of grey levels as float64
_PNM = re.compile(rb"P[1-7]\s*(?:#[^\n]*\n\s*)*(\d+)\s+(?:#[^\n]*\n\s*)*(\d+)")


def open_image(file: Path, fail: Callable[[str], WorldError], kind: str = "image") -> Image.Image:
    """The image at `file`, opened (header read, nothing decoded), with at most MAX_IMAGE_PIXELS pixels; else
    `fail(message)` is raised, the message naming the file, its size and the limit (the largest `kind` taken).
    OSError and PIL's errors for an unreadable file are the caller's to catch."""
    from PIL import Image

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", Image.DecompressionBombWarning)  # the limit below is lower than PIL's
        try:
            image = Image.open(file)
        except Image.DecompressionBombError:
            size = header_size(file)
            raise fail(
                _too_large(
                    file,
                    f"{size[0]} x {size[1]} pixels"
                    if size
                    else f"more than {2 * (Image.MAX_IMAGE_PIXELS or 0)} pixels",
                    kind,
                )
            ) from None
    width, height = image.size
    if width * height > MAX_IMAGE_PIXELS:
        image.close()
        raise fail(_too_large(file, f"{width} x {height} pixels", kind))
    return image


def _too_large(file: Path, size: str, kind: str) -> str:
    return (
        f"{file} is {size}, larger than the largest {kind} taken ({MAX_IMAGE_PIXELS} pixels, e.g. "
        f"{MAX_IMAGE_SIDE} x {MAX_IMAGE_SIDE})"
    )


def header_size(file: Path) -> tuple[int, int] | None:
    """(width, height) from the header of a PNG or a PGM/PPM/PBM file, read without PIL; None for other formats."""
    try:
        with open(file, "rb") as stream:
            head = stream.read(1024)
    except OSError:
        return None
    if head[:8] == b"\x89PNG\r\n\x1a\n" and head[12:16] == b"IHDR":
        width, height = struct.unpack(">II", head[16:24])
        return width, height
    match = _PNM.match(head)
    return (int(match[1]), int(match[2])) if match else None
