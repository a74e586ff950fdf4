"""The camera's frame finishing compiled (numba): GL readback to a top-row-first image, sky painted, noise added.

camera.add_noise's numpy is ~10 passes over the frame (cast, scale, round, clamp, widen, add per channel, clamp,
narrow) plus the copies of the flip, each dropping and retaking the GIL; here a row at a time stays in the cache
between its steps, with the GIL released. The result is add_noise's, value for value (the same float32 operations).

On little-endian machines (an RGBA pixel read as a word has R in its low byte) each row goes through four simple
loops, each of which the compiler vectorises: the sky painted word by word, the noise as words of three equal bytes
(up and down), a saturating add and subtract byte by byte, and the packing of RGBA into three bytes. One loop doing
it all was not vectorised: 1.1 ms of a noisy 640x480 frame against 0.17 ms this way, on the thread that takes the
frame (the simulation's, in a run). Other buffers (not contiguous, or a big-endian machine) go pixel by pixel.
"""

from __future__ import annotations

import sys

import numpy as np
from numba import njit
from numpy.typing import NDArray

_LITTLE_ENDIAN = sys.byteorder == "little"  # an RGBA pixel read as a word has R in its low byte


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
    rows = _LITTLE_ENDIAN and gl_rgba.flags.c_contiguous and out.flags.c_contiguous
    (finish_rows if rows else _finish_pixels)(gl_rgba, sky, fill_sky, table, first, second, stddev, mean, bgr, out)


@njit(cache=True, nogil=True, error_model="numpy")
def _finish_pixels(
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
    """finish_frame() pixel by pixel, for any buffers."""
    height, width = out.shape[0], out.shape[1]
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
def finish_rows(
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
    """finish_frame() for C-contiguous buffers on little-endian machines: the same values, a row at a time in four
    simple loops over one row's words and bytes, each of which the compiler vectorises (a loop that does it all at
    once does not: it took 1.1 ms of a noisy 640x480 frame against 0.17 ms this way)."""
    height, width = out.shape[0], out.shape[1]
    words = gl_rgba.reshape(height * width * 4).view(np.uint32)
    flat = out.reshape(height * width * 3)
    sky_word = np.uint32(sky[0]) | (np.uint32(sky[1]) << np.uint32(8)) | (np.uint32(sky[2]) << np.uint32(16))
    sky_alpha = np.uint32(0) if fill_sky else np.uint32(256)  # 256: an alpha no pixel has
    noisy = stddev != 0 or mean != 0
    row, up, down = np.empty(width, np.uint32), np.empty(width, np.uint32), np.empty(width, np.uint32)
    row_bytes, up_bytes, down_bytes = row.view(np.uint8), up.view(np.uint8), down.view(np.uint8)
    for r in range(height):
        _sky_words(words[(height - 1 - r) * width : (height - r) * width], sky_word, sky_alpha, row)
        if noisy:
            a, b = first + r * width, second + r * width
            _noise_words(table[a : a + width], table[b : b + width], stddev, mean, up, down)
            _saturate(row_bytes, up_bytes, down_bytes)
        dst = flat[r * width * 3 : (r + 1) * width * 3]
        if bgr:
            _pack_bgr(row_bytes, dst)
        else:
            _pack_rgb(row_bytes, dst)


@njit(cache=True, nogil=True)
def _sky_words(src: NDArray[np.uint32], sky_word: np.uint32, sky_alpha: np.uint32, out: NDArray[np.uint32]) -> None:
    """out = src, with the words of alpha `sky_alpha` replaced by `sky_word`."""
    for col in range(src.shape[0]):
        word = src[col]
        out[col] = sky_word if (word >> np.uint32(24)) == sky_alpha else word


@njit(cache=True, nogil=True, error_model="numpy")
def _noise_words(
    ta: NDArray[np.float32],
    tb: NDArray[np.float32],
    stddev: np.float32,
    mean: np.float32,
    up: NDArray[np.uint32],
    down: NDArray[np.uint32],
) -> None:
    """Each pixel's noise k = round(stddev * (ta + tb) + mean), clamped to +-255, as words whose three colour bytes
    are max(k, 0) (`up`) and max(-k, 0) (`down`)."""
    lo, hi = np.float32(-255.0), np.float32(255.0)
    for col in range(up.shape[0]):
        k = np.int32(np.rint(min(max(stddev * (ta[col] + tb[col]) + mean, lo), hi)))
        up[col] = np.uint32(max(k, 0)) * np.uint32(0x010101)
        down[col] = np.uint32(max(-k, 0)) * np.uint32(0x010101)


@njit(cache=True, nogil=True)
def _saturate(pixels: NDArray[np.uint8], up: NDArray[np.uint8], down: NDArray[np.uint8]) -> None:
    """pixels = min(max(pixels + up - down, 0), 255) byte by byte, where one of up and down is 0: a saturating add
    then a saturating subtract, written as the wrap-around tests the compiler turns into single instructions."""
    for j in range(pixels.shape[0]):
        value = pixels[j]
        raised = np.uint8(value + up[j])
        if raised < value:
            raised = np.uint8(255)
        lowered = np.uint8(raised - down[j])
        if lowered > raised:
            lowered = np.uint8(0)
        pixels[j] = lowered


@njit(cache=True, nogil=True)
def _pack_bgr(rgba: NDArray[np.uint8], out: NDArray[np.uint8]) -> None:
    for col in range(out.shape[0] // 3):
        out[3 * col] = rgba[4 * col + 2]
        out[3 * col + 1] = rgba[4 * col + 1]
        out[3 * col + 2] = rgba[4 * col]


@njit(cache=True, nogil=True)
def _pack_rgb(rgba: NDArray[np.uint8], out: NDArray[np.uint8]) -> None:
    for col in range(out.shape[0] // 3):
        out[3 * col] = rgba[4 * col]
        out[3 * col + 1] = rgba[4 * col + 1]
        out[3 * col + 2] = rgba[4 * col + 2]
