"""The wall cast of a map's dense cells (thousands of walls within reach): walls hidden behind nearer hits dropped
before they are cast, with the ranges of kernels.walls_in_band to the last bit.

In a dense map most walls within reach lie behind nearer ones. The fan is cut into sectors of SECTOR_BEAMS beams,
each holding the largest range among its beams; a wall no nearer than that largest range over the sectors it may
span cannot lower any beam, and is dropped before kernels.hit_wall finds its beam interval (two atan2s) and
visits its beams. Its sectors come from a cheap arctangent, widened by a margin far above that arctangent's
error, so only walls the exact cast would have skipped beam by beam are dropped. Consecutive walls in one TILE
square (dense_table lists them so) form a run, tested first as one circle: a run hidden behind nearer hits is
skipped without reading its walls. The bookkeeping costs a sparse world's scan more than it saves (and its code
more cache in a pipeline), so it is only used from DENSE_WALLS walls a cell (grid.FlatWalls).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from racecar_sim.sensors.raycast.kernels import (
    ZHI,
    ZLO,
    Beams,
    Floats,
    Plane,
    facing,
    hit_wall,
    in_plane,
    nearest_point,
    wall_table,
    within_reach,
)

# the rows a dense table adds to a wall table: ZLO_MAX, ZHI_MIN, the highest bottom and lowest top of this wall and
# those after it; RUN_X, RUN_Y, RUN_R, RUN_END: a circle holding the run of consecutive walls in one tile (TILE) that
# this wall belongs to, and the column after the run's last
ZLO_MAX, ZHI_MIN, RUN_X, RUN_Y, RUN_R, RUN_END = range(16, 22)
DENSE_WALLS = 256  # walls in a cell from which the culling pays
TILE = 1.0  # m: walls whose middles share a TILE square are tested as one (a run) before any of them
SECTOR_BEAMS = 16  # beams per sector of the fan (the unit in which walls hidden behind nearer hits are dropped)
_ARC_MARGIN = 1e-4  # rad added to each side of a wall's arc for its sectors: _fast_angle errs by less than 2e-5
_ARC_SURE = 1e-6  # below this |sin| of a wall's arc, its short way round is not trusted to the cheap arctangent


def dense_order(segments: np.ndarray, centre: tuple[float, float]) -> np.ndarray:
    """The column order of a cell's walls for a dense table: by TILE squares, near to far from `centre`, and near
    to far within each."""
    tile = (np.floor(segments[6:8] / TILE) + 0.5) * TILE
    return np.lexsort(
        (
            np.hypot(segments[6] - centre[0], segments[7] - centre[1]),
            tile_keys(segments),
            np.hypot(tile[0] - centre[0], tile[1] - centre[1]),
        )
    )


def dense_table(segments: np.ndarray, range_min: float, range_max: float) -> np.ndarray:
    """kernels.wall_table of `segments` (in dense_order) with the rows above."""
    extra = np.array(
        [
            np.maximum.accumulate(segments[4][::-1])[::-1],
            np.minimum.accumulate(segments[5][::-1])[::-1],
            *_runs(segments),
        ]
    ).reshape(6, -1)
    return np.ascontiguousarray(np.vstack([wall_table(segments, range_min, range_max), extra]))


def tile_keys(segments: np.ndarray) -> np.ndarray:
    """The TILE square of each wall's middle, as one integer per wall (equal keys: the same square)."""
    ix, iy = np.floor(segments[6:8] / TILE).astype(np.int64) + (1 << 20)
    keys: np.ndarray = ix * (1 << 21) + iy
    return keys


def _runs(segments: np.ndarray) -> np.ndarray:
    """Rows RUN_X, RUN_Y, RUN_R, RUN_END: the runs of consecutive walls with the same tile_keys."""
    n = segments.shape[1]
    keys = tile_keys(segments)
    starts = np.flatnonzero(np.r_[True, keys[1:] != keys[:-1]]) if n else np.zeros(0, np.intp)
    ends = np.r_[starts[1:], n].astype(np.intp)
    run = np.repeat(np.arange(len(starts)), ends - starts)
    ends_x = np.concatenate([segments[0], segments[2]])
    ends_y = np.concatenate([segments[1], segments[3]])
    lo_x = np.minimum.reduceat(ends_x.reshape(2, n).min(axis=0), starts) if n else np.zeros(0)
    hi_x = np.maximum.reduceat(ends_x.reshape(2, n).max(axis=0), starts) if n else np.zeros(0)
    lo_y = np.minimum.reduceat(ends_y.reshape(2, n).min(axis=0), starts) if n else np.zeros(0)
    hi_y = np.maximum.reduceat(ends_y.reshape(2, n).max(axis=0), starts) if n else np.zeros(0)
    centre_x, centre_y = 0.5 * (lo_x + hi_x), 0.5 * (lo_y + hi_y)
    # every end point lies within the circle (a margin for rounding); the walls between them too
    reach = (
        np.hypot(ends_x.reshape(2, n) - centre_x[run], ends_y.reshape(2, n) - centre_y[run]).max(axis=0)
        if n
        else np.zeros(0)
    )
    radius = np.maximum.reduceat(reach, starts) * (1.0 + 1e-9) + 1e-9 if n else np.zeros(0)
    return np.array([centre_x[run], centre_y[run], radius[run], ends[run].astype(float)]).reshape(4, n)


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _fast_angle(x: float, y: float) -> float:
    """atan2(y, x) to within 2e-5 rad (Abramowitz & Stegun 4.4.49 on the octant), without a library call."""
    ax, ay = abs(x), abs(y)
    big = max(ax, ay)
    if big == 0.0:
        return 0.0
    z = min(ax, ay) / big
    z2 = z * z
    a = z * (0.9998660 + z2 * (-0.3302995 + z2 * (0.1801410 + z2 * (-0.0851330 + z2 * 0.0208351))))
    if ay > ax:
        a = 0.5 * math.pi - a
    if x < 0.0:
        a = math.pi - a
    return -a if y < 0.0 else a


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _fan_arc(angle: float, width: float, beams: Beams) -> tuple[float, float]:
    """Fan positions (start, end), in beam steps from the first beam with 0 <= start + margin < turn, of the arc
    `width` rad wide from `angle`, widened by the cheap arctangent's margin on each side."""
    angle_min, inverse_step, _, turn = beams
    first = (angle - angle_min) * inverse_step
    while first < 0.0:  # into [0, turn): at most once for a fan starting within a turn of the angle -pi
        first += turn
    while first >= turn:
        first -= turn
    margin = _ARC_MARGIN * inverse_step
    return first - margin, first + width * inverse_step + margin


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _arc(q0x: float, q0y: float, q1x: float, q1y: float, cross: float, beams: Beams) -> tuple[float, float]:
    """Fan positions (start, end) holding every beam the segment q0-q1 (beam plane, origin at 0) spans, the exact
    cast's edge slack included; (0, inf) when its short way round is in doubt (an arc near nothing or a half turn:
    the cheap arctangent cannot tell)."""
    if not abs(cross) > _ARC_SURE * (abs(q0x) + abs(q0y)) * (abs(q1x) + abs(q1y)):
        return 0.0, np.inf
    if cross > 0.0:  # counter-clockwise from end 0 to end 1 is the short way round
        start, end = _fast_angle(q0x, q0y), _fast_angle(q1x, q1y)
    else:
        start, end = _fast_angle(q1x, q1y), _fast_angle(q0x, q0y)
    arc = end - start
    if arc < 0.0:
        arc += 2.0 * math.pi
    return _fan_arc(start, arc, beams)


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _piece(start: float, end: float, shift: float, count: int) -> tuple[float, float]:
    """The part (a, b; none if a > b) on the fan's beams of the arc start..end moved by `shift` (a turn or none)."""
    return max(start + shift, 0.0), min(end + shift, count - 1.0)


@njit(cache=True, nogil=True, error_model="numpy")
def _sector_maxima(ranges: Floats, sectors: Floats, first: int, last: int) -> None:
    """sectors[k] for the sectors holding beams first..last: the largest of their ranges."""
    for k in range(first // SECTOR_BEAMS, last // SECTOR_BEAMS + 1):
        top = -np.inf
        for b in range(k * SECTOR_BEAMS, min((k + 1) * SECTOR_BEAMS, len(ranges))):
            top = max(top, ranges[b])
        sectors[k] = top


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _sectors_within(
    sectors: Floats, start: float, end: float, count: int, turn: float, near: float, squared: bool
) -> bool:
    """Whether every sector holding a beam of the arc start..end (fan positions, once round each way) holds no range
    above `near` (squared: a squared distance, and no range below 0)."""
    shift = -turn
    while start + shift <= count - 1:
        a, b = _piece(start, end, shift, count)
        if a <= b:
            for k in range(int(a) // SECTOR_BEAMS, int(b) // SECTOR_BEAMS + 1):
                top = sectors[k]
                if not ((top >= 0.0 and top * top <= near) if squared else top <= near):
                    return False
        shift += turn
    return True


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _run_hidden(
    tx: float, ty: float, radius: float, plane: Plane, stretch: float, beams: Beams, sectors: Floats
) -> bool:
    """Whether every sector the circle (offset tx, ty from the origin, `radius`) may span holds no range above
    the circle's nearest distance (beam plane): then no wall inside it can lower a beam."""
    p00, p01, p10, p11 = plane
    qx, qy = p00 * tx + p01 * ty, p10 * tx + p11 * ty
    d = math.sqrt(qx * qx + qy * qy)
    r = radius * stretch
    if not d > 2.0 * r:  # near or around the origin: its arc is wide, test its walls one by one
        return False
    near = (d - r) * (1.0 - 1e-6) - 1e-9  # below any wall's nearest in it, rounding of both included
    half = (r / d) * (0.5 * math.pi)  # >= asin(r / d)
    start, end = _fan_arc(_fast_angle(qx, qy) - half, 2.0 * half, beams)
    return _sectors_within(sectors, start, end, beams[2], beams[3], near, False)


@njit(cache=True, nogil=True, error_model="numpy")
def cast_dense(
    table: Floats,
    ox: float,
    oy: float,
    oz: float,
    plane: Plane,
    stretch: float,
    lo: float,
    hi: float,
    beams: Beams,
    range_min: float,
    dirs: Floats,
    ranges: Floats,
) -> None:
    """kernels.walls_in_band for a level scan of walls that cover its band (a dense_table), dropping hidden runs and
    walls (the module doc); a wall not hidden is cast by kernels.hit_wall, and the maxima of the sectors it may span
    are taken again. `stretch`: kernels.stretch_of the plane map."""
    _, _, count, turn = beams
    sectors = np.empty((count + SECTOR_BEAMS - 1) // SECTOR_BEAMS)
    _sector_maxima(ranges, sectors, 0, count - 1)
    stretch = stretch * (1.0 + 1e-9) + 1e-12  # rounded up
    seen = np.empty(table.shape[1], np.intp)
    run_end = 0
    while run_end < table.shape[1]:
        run, run_end = run_end, int(table[RUN_END, run_end])
        radius = table[RUN_R, run]
        if _run_hidden(table[RUN_X, run] - ox, table[RUN_Y, run] - oy, radius, plane, stretch, beams, sectors):
            continue
        # the walls seen (kernels._wall_is_seen for walls covering the band), listed first without a branch per
        # wall: whether a wall is seen is hard to predict
        n = 0
        for w in range(run, run_end):
            seen[n] = w
            n += (
                within_reach(table, w, ox, oy)
                & (table[ZLO, w] <= lo)
                & (table[ZHI, w] >= hi)
                & facing(table, w, ox, oy)
            )
        for i in range(n):
            w = seen[i]
            q0x, q0y, q1x, q1y = in_plane(table, w, ox, oy, plane)
            nx, ny = nearest_point(q0x, q0y, q1x - q0x, q1y - q0y)
            # hidden if every sector it may span holds no range above its nearest point; squared, with a margin
            # (4e-9) over hit_wall's (1e-9 below) that dwarfs the rounding of hypot against a square root
            near2 = (nx * nx + ny * ny) * (1.0 - 4e-9)
            start, end = _arc(q0x, q0y, q1x, q1y, q0x * q1y - q0y * q1x, beams)
            if _hidden(sectors, ranges, near2, start, end, count, turn):
                continue
            hit_wall(table, w, False, ox, oy, oz, plane, (0.0, 0.0), beams, range_min, dirs, ranges)
            shift = -turn  # the maxima of the sectors the arc spans, once round each way
            while start + shift <= count - 1:
                a, b = _piece(start, end, shift, count)
                if a <= b:
                    _sector_maxima(ranges, sectors, int(a), int(b))
                shift += turn


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _hidden(sectors: Floats, ranges: Floats, near2: float, start: float, end: float, count: int, turn: float) -> bool:
    """Whether every beam of the arc start..end (fan positions) holds a range no greater than the square root of
    near2: by sectors, then, for a short arc, beam by beam."""
    hidden = _sectors_within(sectors, start, end, count, turn, near2, True)
    if hidden or end - start >= SECTOR_BEAMS:
        return hidden
    shift = -turn  # a short arc: its beams one by one
    while start + shift <= count - 1:
        a, b = _piece(start, end, shift, count)
        for k in range(math.ceil(a), int(b) + 1):
            top = ranges[k]
            if not (top >= 0.0 and top * top <= near2):
                return False
        shift += turn
    return True
