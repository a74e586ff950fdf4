"""Gazebo's laser rule compiled (numba): noise from a NoiseTable, clamping and float32 in one pass per scan.

The same operations, in the same order, as LidarPublisher's numpy code (true range + (unit noise x stddev +
mean), clamped to [range_min, range_max], +inf where nothing was hit), so either gives the same bits.

level_scan compiles the casts of raycast/level.py, kernels.py, dense.py and solids.py into itself, and numba's cache
(cache=True) knows only each function's own file: after changing one of them in a checkout, delete
src/**/__pycache__/*.nbi (an install starts afresh).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from numpy.typing import NDArray

from racecar_sim.sensors.raycast.kernels import Floats, Indices, clear_past, level_band, plane_map, stretch_of
from racecar_sim.sensors.raycast.level import cast_level
from racecar_sim.sensors.raycast.solids import cast_solids

Noise = NDArray[np.floating]  # a NoiseTable's values


@njit(cache=True, nogil=True, error_model="numpy")
def published_scan(
    ranges: Floats,
    values: Noise,
    first: int,
    second: int,
    stddev: float,
    mean: float,
    noisy: bool,
    range_min: float,
    range_max: float,
    out: NDArray[np.float32],
) -> None:
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
def published_scans(
    ranges: Floats,
    values: Noise,
    first: NDArray[np.intp],
    second: NDArray[np.intp],
    stddev: float,
    mean: float,
    noisy: bool,
    range_min: float,
    range_max: float,
    out: NDArray[np.float32],
) -> None:
    """published_scan for every row i of `ranges` (N, beams), with the windows first[i], second[i]."""
    for i in range(ranges.shape[0]):
        published_scan(ranges[i], values, first[i], second[i], stddev, mean, noisy, range_min, range_max, out[i])


@njit(cache=True, nogil=True, error_model="numpy")
def level_scan(
    qpos: Floats,
    adr: int,
    local_origin: Floats,
    local_axes: Floats,
    size: float,
    x0: int,
    y0: int,
    ids: NDArray[np.int64],
    outside: int,
    starts: NDArray[np.int64],
    table: Floats,
    floors: Floats,
    max_tilt_cos: float,
    angle_min: float,
    inverse_step: float,
    count: int,
    turn: float,
    range_min: float,
    range_max: float,
    dirs: Floats,
    values: Noise,
    first: int,
    second: int,
    stddev: float,
    mean: float,
    noisy: bool,
    ranges: Floats,
    out: NDArray[np.float32],
    xpos: Floats,
    xmat: Floats,
    solid_ids: Indices,
    solid_types: Indices,
    solid_sizes: Floats,
    solid_rbound: Floats,
) -> bool:
    """A whole published scan in one call, for a laser on a free body (LaserMount) in a world of walls and moving
    solids (other cars): the ray origin and axes from the body's pose in qpos (LaserMount.pose's operations, in its
    order), the origin's grid cell (FlatWalls; `outside`: the cell of every point outside `ids`), level.cast_level
    into `ranges` (raycast.dense's cast where the tables are dense_tables: a map, FlatWalls.dense), then
    solids.cast_solids on the geoms `solid_ids` at their poses xpos, xmat (an MjData posed at the live qpos),
    published_scan into `out`. Returns False, `out` untouched, where that path cannot answer (a cell with more than
    walls, or cast_level's refusals)."""
    origin, axes = _laser_pose(qpos, adr, local_origin, local_axes)
    k = _cell(origin, size, x0, y0, ids, outside)
    ranges[:] = np.inf
    if k < 0:
        return False
    cell = table[:, starts[k] : starts[k + 1]]
    walls = (cell, floors, origin, axes, max_tilt_cos, angle_min, inverse_step, count, turn, range_min, range_max)
    if not cast_level(*walls, dirs, ranges):
        return False
    if solid_ids.shape[0]:  # the band, plane map and stretch of the level scan cast_level answered
        _, lo, hi = level_band(floors, origin, axes, max_tilt_cos, range_max)
        plane, det = plane_map(axes)
        solids = (xpos, xmat, solid_ids, solid_types, solid_sizes, solid_rbound, origin, axes)
        beams = (angle_min, inverse_step, count, turn)
        cast_solids(*solids, plane, stretch_of(plane, det), lo, hi, beams, range_min, range_max, dirs, ranges)
        clear_past(ranges, range_max)  # upright boxes are cast as walls are: hits past range_max are none
    published_scan(ranges, values, first, second, stddev, mean, noisy, range_min, range_max, out)
    return True


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _laser_pose(qpos: Floats, adr: int, local_origin: Floats, local_axes: Floats) -> tuple[Floats, Floats]:
    """(ray origin, sensor axes) of the laser on the free body at qpos[adr:] (LaserMount.pose's operations)."""
    px, py, pz = qpos[adr], qpos[adr + 1], qpos[adr + 2]
    w, x, y, z = qpos[adr + 3], qpos[adr + 4], qpos[adr + 5], qpos[adr + 6]
    r = np.empty((3, 3))
    r[0, 0], r[0, 1], r[0, 2] = 1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)
    r[1, 0], r[1, 1], r[1, 2] = 2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)
    r[2, 0], r[2, 1], r[2, 2] = 2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)
    origin = np.empty(3)
    axes = np.empty((3, 3))
    p = (px, py, pz)
    for i in range(3):
        origin[i] = p[i] + (r[i, 0] * local_origin[0] + r[i, 1] * local_origin[1] + r[i, 2] * local_origin[2])
        for j in range(3):
            axes[i, j] = r[i, 0] * local_axes[0, j] + r[i, 1] * local_axes[1, j] + r[i, 2] * local_axes[2, j]
    return origin, axes


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _cell(origin: Floats, size: float, x0: int, y0: int, ids: NDArray[np.int64], outside: int) -> int:
    """The FlatWalls cell number of `origin`; -1 where FlatWalls has no walls-only cell."""
    ix, iy = math.floor(origin[0] / size) - x0, math.floor(origin[1] / size) - y0
    if ix < 0 or iy < 0 or ix >= ids.shape[0] or iy >= ids.shape[1]:
        return outside
    return int(ids[ix, iy])


@njit(cache=True, nogil=True, error_model="numpy")
def level_scans(
    qpos: Floats,
    adrs: Indices,
    local_origins: Floats,
    local_axes: Floats,
    size: float,
    x0: int,
    y0: int,
    ids: NDArray[np.int64],
    outside: int,
    starts: NDArray[np.int64],
    table: Floats,
    floors: Floats,
    max_tilt_cos: float,
    angle_min: float,
    inverse_step: float,
    count: int,
    turn: float,
    range_min: float,
    range_max: float,
    dirs: Floats,
    values: Noise,
    firsts: Indices,
    seconds: Indices,
    stddevs: Floats,
    means: Floats,
    noisy: NDArray[np.bool_],
    ranges: Floats,
    out: NDArray[np.float32],
    xpos: Floats,
    xmat: Floats,
    solid_starts: Indices,
    solid_ids: Indices,
    solid_types: Indices,
    solid_sizes: Floats,
    solid_rbound: Floats,
    cast: NDArray[np.bool_],
) -> None:
    """level_scan for the lasers i = 0..n-1 of one world's walls and fan, in one call (a fleet's scans of one tick):
    laser i on the free body at qpos[adrs[i]:], its mount local_origins[i], local_axes[i], its noise table values[i]
    (rows: the tables, stacked) with the windows firsts[i], seconds[i], its noise stddevs[i], means[i], noisy[i], its
    scratch ranges[i] and scan out[i], the solids it sees solid_ids[solid_starts[i]:solid_starts[i + 1]] (and their
    types, sizes, bounds). cast[i]: level_scan's answer (False: out[i] untouched, the scan needs the general path)."""
    for i in range(adrs.shape[0]):
        a, b = solid_starts[i], solid_starts[i + 1]
        cast[i] = level_scan(
            qpos,
            adrs[i],
            local_origins[i],
            local_axes[i],
            size,
            x0,
            y0,
            ids,
            outside,
            starts,
            table,
            floors,
            max_tilt_cos,
            angle_min,
            inverse_step,
            count,
            turn,
            range_min,
            range_max,
            dirs,
            values[i],
            firsts[i],
            seconds[i],
            stddevs[i],
            means[i],
            noisy[i],
            ranges[i],
            out[i],
            xpos,
            xmat,
            solid_ids[a:b],
            solid_types[a:b],
            solid_sizes[a:b],
            solid_rbound[a:b],
        )
