"""Opening the images a world is made of (occupancy maps, albedo maps) with their size checked before any decoding.

PIL reads only the header on open; the pixels are decoded on load. A map of 20000 x 20000 cells would take gigabytes
(and PIL refuses to open one, as a decompression bomb), so the size is checked against MAX_IMAGE_PIXELS first.

A texture's RGBA pixels are kept on disk once decoded (`rgba_pixels`), so that a run in a world with one does not
import PIL (0.02-0.05 s of a walker run's start) to decode the same file again. An entry is used only if its header
names the very file it was decoded from: its resolved path, size and modification time, PIL's version and this
format. Entries live in ~/.cache/racecar-sim/images/ (or under $XDG_CACHE_HOME); RACECAR_SIM_IMAGE_CACHE=0 turns
the cache off, and a cache that cannot be written is simply not kept.
"""

from __future__ import annotations

import json
import os
import re
import struct
import warnings
import zlib
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from racecar_sim.core.errors import WorldError
from racecar_sim.core.noise_cache import cache_dir as _noise_dir
from racecar_sim.core.noise_cache import keep_entry

if TYPE_CHECKING:  # PIL (~10 ms) is imported by the first world that has an image, not by every run
    from PIL import Image

MAX_IMAGE_SIDE = 8192  # the largest map is MAX_IMAGE_SIDE x MAX_IMAGE_SIDE cells, or any shape of as many
MAX_IMAGE_PIXELS = MAX_IMAGE_SIDE * MAX_IMAGE_SIDE  # 67 million: half a gigabyte of grey levels as float64
IMAGE_CACHE_FORMAT = 1  # bump when what rgba_pixels returns for a file changes
IMAGE_CACHE_VARIABLE = "RACECAR_SIM_IMAGE_CACHE"
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


def rgba_pixels(file: Path, fail: Callable[[str], WorldError], kind: str = "image") -> np.ndarray:
    """The image at `file` as an (height, width, 4) uint8 RGBA array: the kept one where the file is the one it was
    decoded from, else opened (open_image: its size checked) and converted by PIL, then kept. OSError and PIL's
    errors for an unreadable file are the caller's to catch."""
    header = _image_header(file)
    path = _image_dir() / f"{zlib.crc32(header):08x}.bin" if header is not None else None
    kept = _kept_pixels(path, header) if path is not None and header is not None else None
    if kept is not None:
        return kept
    with open_image(file, fail, kind) as image:
        pixels = np.asarray(image.convert("RGBA"))
    if path is not None and header is not None:
        shape = json.dumps(list(pixels.shape[:2])).encode() + b"\n"
        keep_entry(path, header, shape, np.ascontiguousarray(pixels).tobytes())
    return pixels


def _image_dir() -> Path:
    return _noise_dir().parent / "images"


def _image_header(file: Path) -> bytes | None:
    """What an entry for `file` must name, or None where the cache is off (or the file cannot be looked at)."""
    if os.environ.get(IMAGE_CACHE_VARIABLE, "1") == "0":
        return None
    import PIL  # its version only (3 ms): PIL.Image is what the cache spares

    try:
        resolved = file.resolve()
        stat = resolved.stat()
    except OSError:
        return None
    fields = [IMAGE_CACHE_FORMAT, str(resolved), stat.st_size, stat.st_mtime_ns, PIL.__version__]
    return json.dumps(fields).encode() + b"\n"


def _kept_pixels(path: Path, header: bytes) -> np.ndarray | None:
    try:
        with path.open("rb") as stream:
            if stream.readline() != header:
                return None
            height, width = json.loads(stream.readline())
            pixels = np.fromfile(stream, dtype=np.uint8)
    except (OSError, ValueError):
        return None
    if pixels.size != height * width * 4:  # a cut entry (a full disk): decoded again
        return None
    return pixels.reshape(height, width, 4)
