"""Gazebo's laser rule compiled (numba): noise from a NoiseTable, clamping and float32 in one pass per scan.

The same operations, in the same order, as LidarPublisher's numpy code (true range + (unit noise x stddev +
mean), clamped to [range_min, range_max], +inf where nothing was hit), so either gives the same bits.
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True, nogil=True, error_model="numpy")
def published_scan(ranges, values, first, second, stddev, mean, noisy, range_min, range_max, out):  # noqa: ANN001, ANN201
    """out (float32) = the published scan of the true `ranges` (float64), with the noise of the table windows
    values[first:] + values[second:] when `noisy`."""
    for b in range(ranges.shape[0]):
        r = ranges[b]
        if r == np.inf:
            out[b] = np.inf
            continue
        if noisy:
            r = r + ((values[first + b] + values[second + b]) * stddev + mean)
        out[b] = min(max(r, range_min), range_max)


@njit(cache=True, nogil=True, error_model="numpy")
def published_scans(ranges, values, first, second, stddev, mean, noisy, range_min, range_max, out):  # noqa: ANN001, ANN201
    """published_scan for every row i of `ranges` (N, beams), with the windows first[i], second[i]."""
    for i in range(ranges.shape[0]):
        published_scan(ranges[i], values, first[i], second[i], stddev, mean, noisy, range_min, range_max, out[i])
