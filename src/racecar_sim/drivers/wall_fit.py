"""The wall-follow driver's wall fit, compiled (numba): one call per scan instead of ~25 numpy calls (read_scan: with
the scan's other readings, the NaN check and the free distance ahead, in the same call).

Loaded by the first scan that has two echoes on the followed side (a world with walls; numba is already loaded
there by the lidar's wall cast).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

TIE = 1.0 + 1e-12  # ranges closer than this ratio may order differently by x^2 + y^2 (rounding)


@njit(cache=True, nogil=True, error_model="numpy")
def fit_wall(ranges, cos, sin, range_max, patch, side):
    """(approach angle, distance) of the wall: WallFollower._fit's definition (see there), as loops.

    ranges: the side sector's ranges (no NaN or -inf); cos, sin: its beams' unit vectors.
    """
    n = len(ranges)
    hits = 0
    index = -1
    for j in range(n):
        if ranges[j] < range_max:
            hits += 1
        if index < 0 or ranges[j] < ranges[index]:
            index = j
    if hits < 2:
        return 0.0, range_max
    shortest = float(ranges[index])
    ties = 0
    for j in range(n):
        if ranges[j] <= shortest * TIE:
            ties += 1
    if shortest < 0.0 or ties > 1:  # x^2 + y^2 decides, among the hits
        best = math.inf
        for j in range(n):
            if ranges[j] < range_max:
                x, y = ranges[j] * cos[j], ranges[j] * sin[j]
                if x * x + y * y < best:
                    best, index = x * x + y * y, j
    nx, ny = ranges[index] * cos[index], ranges[index] * sin[index]
    patch_squared = patch * patch * (1.0 + 1e-9)
    count, sx, sy = 0, 0.0, 0.0
    for j in range(n):
        if ranges[j] < range_max:
            dx, dy = ranges[j] * cos[j] - nx, ranges[j] * sin[j] - ny
            if dx * dx + dy * dy <= patch_squared and math.hypot(dx, dy) <= patch:
                count += 1
                sx += dx
                sy += dy
    if count < 2:
        return 0.0, math.hypot(nx, ny)
    mx, my = sx / count, sy / count
    sxx_yy, sxy = 0.0, 0.0  # the scatter sum((p - c)^2) of the patch as a complex number
    for j in range(n):
        if ranges[j] < range_max:
            dx, dy = ranges[j] * cos[j] - nx, ranges[j] * sin[j] - ny
            if dx * dx + dy * dy <= patch_squared and math.hypot(dx, dy) <= patch:
                dx -= mx
                dy -= my
                sxx_yy += dx * dx - dy * dy
                sxy += 2.0 * dx * dy
    t = 0.5 * math.atan2(sxy, sxx_yy)
    cx, cy = nx + mx, ny + my
    return -side * t, abs(cx * math.sin(t) - cy * math.cos(t))


@njit(cache=True, nogil=True, error_model="numpy")
def read_scan(ranges, sector_start, sector_stop, cos, sin, front_start, front_stop, range_max, patch, side):
    """WallFollower._on_scan's readings of a float32 scan in one call: (clean, approach, distance, front). `clean`
    False (the rest unset) when a beam is NaN or -inf (the caller's nan_to_num path decides); else fit_wall of the
    side sector ranges[sector_start:sector_stop] (none when fewer than two of its beams are below range_max, compared
    in float32 as numpy compares a float32 array with a float) and the free distance in the front cone
    ranges[front_start:front_stop] (range_max where it is empty or farther)."""
    for j in range(len(ranges)):
        r = ranges[j]
        if math.isnan(r) or r == -math.inf:
            return False, 0.0, 0.0, 0.0
    limit = np.float32(range_max)
    hits = 0
    for j in range(sector_start, sector_stop):
        if ranges[j] < limit:
            hits += 1
    approach, distance = 0.0, range_max
    if hits >= 2:
        approach, distance = fit_wall(ranges[sector_start:sector_stop], cos, sin, range_max, patch, side)
    front = range_max
    if front_stop > front_start:
        lowest = ranges[front_start]
        for j in range(front_start + 1, front_stop):
            lowest = min(lowest, ranges[j])
        front = min(float(lowest), range_max)
    return True, approach, distance, front
