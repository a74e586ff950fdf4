"""The writer process's colour conversion compiled (numba): a bgr8 camera frame read once into the JPEG's and the
video's 4:2:0 planes (recording/colour.py picks this path or the encoders' own).

JPEG: libjpeg-turbo's JFIF conversion (jccolor.c, fixed point with 16 fraction bits, full range) and its h2v2
downsampling (jcsample.c: each 2x2 block's sum plus a bias of 1, 2, 1, 2, ... along the row, shifted down by 2), so
that simplejpeg.encode_jpeg_yuv_planes makes the bytes encode_jpeg makes from the BGR pixels.

Video: limited-range BT.601 yuv420p. Luma as libswscale makes it for bgr24 (input.c's bgr24ToY_c: 15-bit
coefficients, truncated), value for value; chroma is the JPEG's 2x2 means scaled to 224 levels around 128, within
two levels of libswscale's (which sums pixel pairs, filters rows, and puts grey at 127).
"""

from __future__ import annotations

import numpy as np
from numba import njit
from numpy.typing import NDArray

_SCALE = 1 << 16


def _fix(x: float) -> int:
    return int(x * _SCALE + 0.5)


# jccolor.c: FIX(x), ONE_HALF and CBCR_OFFSET
_JY_R, _JY_G, _JY_B = _fix(0.29900), _fix(0.58700), _fix(0.11400)
_JCB_R, _JCB_G, _JCB_B = -_fix(0.16874), -_fix(0.33126), _fix(0.5)
_JCR_R, _JCR_G, _JCR_B = _fix(0.5), -_fix(0.41869), -_fix(0.08131)
_J_HALF = 1 << 15
_J_CHROMA_OFFSET = (128 << 16) + _J_HALF - 1

# the video's luma as libswscale's bgr24ToY_c computes it (RGB2YUV_SHIFT 15: BT.601 scaled to 219 levels from 16,
# truncated), and its chroma scaled from the JPEG's (224 levels around 128)
_SHIFT = 15
_VY_R, _VY_G, _VY_B = (round(c * 219 / 255 * (1 << _SHIFT)) for c in (0.299, 0.587, 0.114))
_VY_OFFSET = 16 << _SHIFT
_CHROMA_SCALE = round(224 / 255 * _SCALE)
_CHROMA_OFFSET = (128 << 16) - 128 * _CHROMA_SCALE


@njit(cache=True, nogil=True)
def bgr_to_planes(
    bgr: NDArray[np.uint8],
    jpeg_y: NDArray[np.uint8],
    jpeg_cb: NDArray[np.uint8],
    jpeg_cr: NDArray[np.uint8],
    video: bool,
    video_y: NDArray[np.uint8],
    video_u: NDArray[np.uint8],
    video_v: NDArray[np.uint8],
) -> None:
    """`bgr` (h, 3 w) uint8 (a bgr8 image's rows) with h and w even -> the JPEG's planes: Y (h, w), Cb and Cr
    (h/2, w/2); and, if `video`, the video's (the same shapes; rows may be longer, as a frame's line size).

    A row pair at a time, in loops the compiler vectorises (int32 arithmetic: 8 pixels a step): each pixel's
    Y, Cb and Cr, and the video's luma, from one read of its bytes (a second pass for the video's luma cost 0.1 ms
    more of a 640x480 frame); the 2x2 blocks' means; the video's chroma scaled from the JPEG's."""
    height, width = bgr.shape[0], bgr.shape[1] // 3
    half = width // 2
    cb = np.empty((2, width), np.int32)
    cr = np.empty((2, width), np.int32)
    for pair in range(height // 2):
        for k in range(2):
            pixels, luma, cb_k, cr_k = bgr[2 * pair + k], jpeg_y[2 * pair + k], cb[k], cr[k]
            vluma = video_y[2 * pair + k]
            if video:
                for x in range(width):
                    b, g, r = np.int32(pixels[3 * x]), np.int32(pixels[3 * x + 1]), np.int32(pixels[3 * x + 2])
                    luma[x] = np.uint8(_dot(r, g, b, _JY_R, _JY_G, _JY_B, _J_HALF) >> 16)
                    cb_k[x] = _dot(r, g, b, _JCB_R, _JCB_G, _JCB_B, _J_CHROMA_OFFSET) >> 16
                    cr_k[x] = _dot(r, g, b, _JCR_R, _JCR_G, _JCR_B, _J_CHROMA_OFFSET) >> 16
                    vluma[x] = np.uint8(_dot(r, g, b, _VY_R, _VY_G, _VY_B, _VY_OFFSET) >> _SHIFT)
            else:
                for x in range(width):
                    b, g, r = np.int32(pixels[3 * x]), np.int32(pixels[3 * x + 1]), np.int32(pixels[3 * x + 2])
                    luma[x] = np.uint8(_dot(r, g, b, _JY_R, _JY_G, _JY_B, _J_HALF) >> 16)
                    cb_k[x] = _dot(r, g, b, _JCB_R, _JCB_G, _JCB_B, _J_CHROMA_OFFSET) >> 16
                    cr_k[x] = _dot(r, g, b, _JCR_R, _JCR_G, _JCR_B, _J_CHROMA_OFFSET) >> 16
        out_cb, out_cr = jpeg_cb[pair], jpeg_cr[pair]
        for col in range(half):
            x = 2 * col
            bias = np.int32(1 + (col & 1))
            out_cb[col] = np.uint8(np.int32(cb[0, x] + cb[0, x + 1] + cb[1, x] + cb[1, x + 1] + bias) >> 2)
            out_cr[col] = np.uint8(np.int32(cr[0, x] + cr[0, x + 1] + cr[1, x] + cr[1, x + 1] + bias) >> 2)
        if video:
            out_u, out_v = video_u[pair], video_v[pair]
            for col in range(half):
                out_u[col] = np.uint8(np.int32(np.int32(out_cb[col]) * _CHROMA_SCALE + _CHROMA_OFFSET) >> 16)
                out_v[col] = np.uint8(np.int32(np.int32(out_cr[col]) * _CHROMA_SCALE + _CHROMA_OFFSET) >> 16)


@njit(cache=True, nogil=True, inline="always")
def _dot(r: np.int32, g: np.int32, b: np.int32, kr: int, kg: int, kb: int, offset: int) -> np.int32:
    """kr r + kg g + kb b + offset in int32 (numba would widen each product to int64: half the vector width)."""
    return np.int32(
        np.int32(np.int32(kr) * r) + np.int32(np.int32(kg) * g) + np.int32(np.int32(kb) * b) + np.int32(offset)
    )
