"""The compiled frame finishing (sensors/camera_noise.py) against numpy: flip, channel order, painted sky and
Gazebo's noise, value for value, on the word-wise path (width a multiple of 4) and the byte-wise one."""

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


@pytest.mark.parametrize("width", [640, 8, 6, 1])  # 6 and 1: the byte-wise path
@pytest.mark.parametrize("bgr", [True, False])
@pytest.mark.parametrize("fill_sky", [True, False])
@pytest.mark.parametrize("noisy", [True, False])
def test_finish_frame_is_numpys_flip_sky_and_noise(width, bgr, fill_sky, noisy):
    rng = np.random.default_rng(width * 8 + bgr * 4 + fill_sky * 2 + noisy)
    height = 5
    gl_rgba = rng.integers(0, 256, (height, width, 4), dtype=np.uint8)
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
