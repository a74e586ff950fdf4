"""The camera's frame finishing compiled (numba): GL readback to a top-row-first image, sky painted, noise added,
one pass.

camera.add_noise's numpy is ~10 passes over the frame (cast, scale, round, clamp, widen, add per channel, clamp,
narrow) plus the copies of the flip, each dropping and retaking the GIL; here each pixel is read once and
written once, with the GIL released. The result is add_noise's, value for value (the same float32 operations).

Where a row is a whole number of 32-bit words (the width a multiple of 4) each GL pixel is read as one word and
every 4 output pixels are written as 3 words: byte-by-byte stores 3 apart keep the compiler from vectorising, and
took 0.7 ms of a 640x480 frame against 0.2 ms this way (the GL thread's critical path).
"""

from __future__ import annotations

import sys

import numpy as np
from numba import njit
from numpy.typing import NDArray

_LITTLE_ENDIAN = sys.byteorder == "little"  # an RGBA pixel read as a word has R in its low byte


@njit(cache=True, nogil=True, error_model="numpy")
def finish_frame(
    gl_rgba: NDArray[np.uint8],
    sky: NDArray[np.uint8],
    fill_sky: bool,
    table: NDArray[np.float32],
    first: int,
    second: int,
    stddev: np.float32,
    mean: np.float32,
    bgr: bool,
    out: NDArray[np.uint8],
) -> None:
    """`out` (h, w, 3) uint8 = the GL buffer `gl_rgba` (h, w, 4, bottom row first) flipped to top row first, in BGR
    order if `bgr`, the pixels of alpha 0 painted `sky` (3 uint8, RGB) if `fill_sky` (render.flat_sky), plus per
    pixel p = row * w + column the noise round(stddev * (table[first + p] + table[second + p]) + mean) (a
    NoiseTable's windows: unit normals) on every channel, clamped to 0-255. stddev = 0 and mean = 0: no noise."""
    height, width = out.shape[0], out.shape[1]
    if _LITTLE_ENDIAN and width % 4 == 0 and gl_rgba.flags.c_contiguous and out.flags.c_contiguous:
        _finish_words(gl_rgba, sky, fill_sky, table, first, second, stddev, mean, bgr, out)
        return
    noisy = stddev != 0 or mean != 0
    first_ch, last_ch = (2, 0) if bgr else (0, 2)
    sky_first, sky_mid, sky_last = np.int32(sky[first_ch]), np.int32(sky[1]), np.int32(sky[last_ch])
    noise = np.zeros(width, dtype=np.int32)
    for row in range(height):
        src = gl_rgba[height - 1 - row]
        dst = out[row]
        if noisy:  # apart from the rest, so that both loops vectorise
            _row_noise(table, first + row * width, second + row * width, stddev, mean, noise)
        for col in range(width):
            k = noise[col]
            is_sky = fill_sky and src[col, 3] == 0
            c0 = sky_first if is_sky else np.int32(src[col, first_ch])
            c1 = sky_mid if is_sky else np.int32(src[col, 1])
            c2 = sky_last if is_sky else np.int32(src[col, last_ch])
            dst[col, 0] = min(max(c0 + k, 0), 255)
            dst[col, 1] = min(max(c1 + k, 0), 255)
            dst[col, 2] = min(max(c2 + k, 0), 255)


@njit(cache=True, nogil=True, error_model="numpy")
def _row_noise(
    table: NDArray[np.float32], first: int, second: int, stddev: np.float32, mean: np.float32, noise: NDArray[np.int32]
) -> None:
    """noise[col] = round(stddev * (table[first + col] + table[second + col]) + mean), clamped to +-255."""
    for col in range(noise.shape[0]):
        x = stddev * (table[first + col] + table[second + col]) + mean
        noise[col] = np.int32(np.rint(min(max(x, np.float32(-255.0)), np.float32(255.0))))


@njit(cache=True, nogil=True, error_model="numpy")
def _finish_words(
    gl_rgba: NDArray[np.uint8],
    sky: NDArray[np.uint8],
    fill_sky: bool,
    table: NDArray[np.float32],
    first: int,
    second: int,
    stddev: np.float32,
    mean: np.float32,
    bgr: bool,
    out: NDArray[np.uint8],
) -> None:
    """finish_frame() for a width that is a multiple of 4, on little-endian machines: the same values, word-wise."""
    height, width = out.shape[0], out.shape[1]
    noisy = stddev != 0 or mean != 0
    shift_first, shift_last = (16, 0) if bgr else (0, 16)  # where the first and last output channel sit in a word
    sky_first, sky_mid, sky_last = np.int32(sky[2 if bgr else 0]), np.int32(sky[1]), np.int32(sky[0 if bgr else 2])
    sky_alpha = np.uint32(0) if fill_sky else np.uint32(256)  # 256: an alpha no pixel has
    noise = np.zeros(width, dtype=np.int32)
    channels = np.empty((3, width), dtype=np.int32)
    words_in = gl_rgba.reshape(height, width * 4).view(np.uint32)
    words_out = out.reshape(height, width * 3).view(np.uint32)
    for row in range(height):
        src = words_in[height - 1 - row]
        dst = words_out[row]
        if noisy:
            _row_noise(table, first + row * width, second + row * width, stddev, mean, noise)
        for col in range(width):
            word = src[col]
            is_sky = (word >> np.uint32(24)) == sky_alpha
            k = noise[col]
            c0 = sky_first if is_sky else np.int32((word >> np.uint32(shift_first)) & np.uint32(255))
            c1 = sky_mid if is_sky else np.int32((word >> np.uint32(8)) & np.uint32(255))
            c2 = sky_last if is_sky else np.int32((word >> np.uint32(shift_last)) & np.uint32(255))
            channels[0, col] = min(max(c0 + k, 0), 255)
            channels[1, col] = min(max(c1 + k, 0), 255)
            channels[2, col] = min(max(c2 + k, 0), 255)
        c = channels
        for q in range(width // 4):  # pixels 4q..4q+3, 12 bytes: 3 words, lowest byte first
            i = 4 * q
            dst[3 * q] = np.uint32(c[0, i] | (c[1, i] << 8) | (c[2, i] << 16) | (c[0, i + 1] << 24))
            dst[3 * q + 1] = np.uint32(c[1, i + 1] | (c[2, i + 1] << 8) | (c[0, i + 2] << 16) | (c[1, i + 2] << 24))
            dst[3 * q + 2] = np.uint32(c[2, i + 2] | (c[0, i + 3] << 8) | (c[1, i + 3] << 16) | (c[2, i + 3] << 24))
