"""The camera's frame finishing compiled (numba): GL readback to a top-row-first image, sky painted, noise added,
one pass.

camera.add_noise's numpy is ~10 passes over the frame (cast, scale, round, clamp, widen, add per channel, clamp,
narrow) plus the copies of the flip, each dropping and retaking the GIL; here each pixel is read once and
written once, with the GIL released. The result is add_noise's, value for value (the same float32 operations).
"""

from __future__ import annotations

import numpy as np
from numba import njit
from numpy.typing import NDArray


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
    noisy = stddev != 0 or mean != 0
    first_ch, last_ch = (2, 0) if bgr else (0, 2)
    sky_first, sky_mid, sky_last = np.int32(sky[first_ch]), np.int32(sky[1]), np.int32(sky[last_ch])
    noise = np.zeros(width, dtype=np.int32)
    for row in range(height):
        src = gl_rgba[height - 1 - row]
        dst = out[row]
        if noisy:
            base = row * width
            for col in range(width):  # apart from the rest, so that both loops vectorise
                x = stddev * (table[first + base + col] + table[second + base + col]) + mean
                noise[col] = np.int32(np.rint(min(max(x, np.float32(-255.0)), np.float32(255.0))))
        for col in range(width):
            k = noise[col]
            is_sky = fill_sky and src[col, 3] == 0
            c0 = sky_first if is_sky else np.int32(src[col, first_ch])
            c1 = sky_mid if is_sky else np.int32(src[col, 1])
            c2 = sky_last if is_sky else np.int32(src[col, last_ch])
            dst[col, 0] = min(max(c0 + k, 0), 255)
            dst[col, 1] = min(max(c1 + k, 0), 255)
            dst[col, 2] = min(max(c2 + k, 0), 255)
