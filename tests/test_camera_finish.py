"""The compiled frame finishing (sensors/camera_noise.py) against numpy: flip, channel order, painted sky and
Gazebo's noise, value for value, on the row-wise path (contiguous buffers) and the pixel-by-pixel one."""

from __future__ import annotations

import numpy as np
import pytest

from racecar_sim.sensors.camera import add_noise
from racecar_sim.sensors.camera_noise import finish_frame


def reference(gl_rgba, sky, fill_sky, table, first, second, stddev, mean, bgr):
    height, width = gl_rgba.shape[:2]
    rgb = gl_rgba[::-1, :, :3].copy()
    if fill_sky:
        rgb[gl_rgba[::-1, :, 3] == 0] = sky
    pixels = rgb[..., ::-1] if bgr else rgb
    unit = table[first : first + height * width] + table[second : second + height * width]
    if stddev == 0 and mean == 0:
        return np.ascontiguousarray(pixels)
    return add_noise(np.ascontiguousarray(pixels), unit.astype(np.float32), float(mean), float(stddev))


@pytest.mark.parametrize("width", [640, 8, 6, 1])
@pytest.mark.parametrize("bgr", [True, False])
@pytest.mark.parametrize("fill_sky", [True, False])
@pytest.mark.parametrize("noisy", [True, False])
@pytest.mark.parametrize("contiguous", [True, False])  # False: the pixel-by-pixel path
def test_finish_frame_is_numpys_flip_sky_and_noise(width, bgr, fill_sky, noisy, contiguous):
    rng = np.random.default_rng(width * 16 + bgr * 8 + fill_sky * 4 + noisy * 2 + contiguous)
    height = 5
    drawn = rng.integers(0, 256, (height, 2 * width, 4), dtype=np.uint8)
    gl_rgba = np.ascontiguousarray(drawn[:, :width]) if contiguous else drawn[:, ::2]
    gl_rgba[..., 3] = np.where(rng.random((height, width)) < 0.3, 0, 255)  # sky where nothing was drawn
    gl_rgba[0, 0, :3] = (250, 3, 128)  # near both clamps
    sky = np.array([178, 170, 160], np.uint8)
    table = (rng.standard_normal(4 * height * width + 10) * (60 if noisy else 0)).astype(np.float32)
    stddev, mean = (np.float32(1.785), np.float32(0.5)) if noisy else (np.float32(0), np.float32(0))
    first, second = 3, 2 * height * width + 7
    out = np.empty((height, width, 3), np.uint8)
    finish_frame(gl_rgba, sky, fill_sky, table, first, second, stddev, mean, bgr, out)
    want = reference(gl_rgba, sky, fill_sky, table, first, second, stddev, mean, bgr)
    assert np.array_equal(out, want), f"{(out != want).any(axis=2).sum()} pixels differ"
