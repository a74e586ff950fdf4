"""The 2-D wall cast compiled (numba): planar.cast_segments' formulas as loops, one scan or a batch of scans.

numpy's cost in the wall cast is per call, not per element (~40 array operations and their temporaries per
scan: tens of microseconds for a scan that is a few thousand multiply-adds). Here a scan is one call: each
wall is culled (out of reach, facing away, outside the height band), its beam interval found from the angles
of its ends, and those beams intersected with it, in place on the ranges. The kernels release the GIL, so a
batch's worlds are cast on the physics threads.

In a dense map most walls within reach lie behind nearer ones. The fan is cut into sectors of SECTOR_BEAMS
beams, each holding the largest range among its beams; a wall no nearer than that largest range over the
sectors it may span cannot lower any beam, and is dropped before its beam interval is found (two atan2s)
and its beams are visited. Its sectors come from a cheap arctangent, widened by a margin far above that
arctangent's error, so only walls the exact cast would have skipped beam by beam are dropped. Consecutive
walls in one TILE square (a grid cell lists them so, see grid.Cell) form a run, tested first as one circle:
a run hidden behind nearer hits is skipped without reading its walls.

A wall table has one column per wall (segment), rows WALL_ROWS (see wall_table). The results are those of
the numpy code beam for beam, to the last bit of t: the same operations in the same order (no fast-math).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from racecar_sim.sensors.raycast.fan import INDEX_SLACK

# rows of a wall table; ZLO_MAX, ZHI_MIN: the highest bottom and lowest top of this wall and those after it;
# RUN_X, RUN_Y, RUN_R, RUN_END: a circle holding the run of consecutive walls in one tile (see TILE) that this wall
# belongs to, and the column after the run's last (relative to the table's first column)
(X0, Y0, X1, Y1, ZLO, ZHI, MIDX, MIDY, REACH2, CX, CY, CREACH2, CROSS, EX, EY, TWO_SIDED, ZLO_MAX, ZHI_MIN,
 RUN_X, RUN_Y, RUN_R, RUN_END) = range(22)
WALL_ROWS = 22
TILE = 1.0  # m: walls whose middles share a TILE square are tested as one (a run) before any of them, if consecutive
_CULL_SLACK = 1.0 + 1e-9  # the reach tests only cull: a wall kept too many changes no range
SECTOR_BEAMS = 16  # beams per sector of the fan (the unit in which walls hidden behind nearer hits are dropped)
_ARC_MARGIN = 1e-4  # rad added to each side of a wall's arc for its sectors: _fast_angle errs by less than 2e-5
_ARC_SURE = 1e-6  # below this |sin| of a wall's arc, its short way round is not trusted to the cheap arctangent


def tile_keys(segments: np.ndarray) -> np.ndarray:
    """The TILE square of each wall's middle, as one integer per wall (equal keys: the same square)."""
    ix, iy = (np.floor(segments[6:8] / TILE).astype(np.int64) + (1 << 20))
    return ix * (1 << 21) + iy


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
    reach = np.hypot(ends_x.reshape(2, n) - centre_x[run], ends_y.reshape(2, n) - centre_y[run]).max(axis=0) if n \
        else np.zeros(0)
    radius = np.maximum.reduceat(reach, starts) * (1.0 + 1e-9) + 1e-9 if n else np.zeros(0)
    return np.array([centre_x[run], centre_y[run], radius[run], ends[run].astype(float)]).reshape(4, n)


def wall_table(segments: np.ndarray, range_min: float, range_max: float) -> np.ndarray:
    """The kernels' table (WALL_ROWS, n) of a scene.py segment table (13, n)."""
    x0, y0, x1, y1 = segments[:4]
    return np.ascontiguousarray(np.array([
        x0, y0, x1, y1, segments[4], segments[5], segments[6], segments[7],
        ((segments[8] + range_max) * _CULL_SLACK) ** 2,  # a wall's points lie within half its length of its middle
        segments[9], segments[10], ((segments[11] + range_min) * _CULL_SLACK) ** 2,
        x0 * y1 - y0 * x1, x1 - x0, y1 - y0, (segments[12] == 0).astype(float),
        np.maximum.accumulate(segments[4][::-1])[::-1], np.minimum.accumulate(segments[5][::-1])[::-1],
        *_runs(segments),
    ]).reshape(WALL_ROWS, -1))


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _fast_angle(x, y):  # noqa: ANN001, ANN202
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
def _arc(q0x, q0y, q1x, q1y, cross, angle_min, inverse_step, turn):  # noqa: ANN001, ANN202
    """Fan positions (lo, hi), in beam steps from the first beam with 0 <= lo < turn + margin, holding every beam
    the segment q0-q1 (beam plane, origin at 0) spans, the exact cast's edge slack included; (0, inf) when its
    short way round is in doubt (an arc near nothing or a half turn: the cheap arctangent cannot tell)."""
    if not abs(cross) > _ARC_SURE * (abs(q0x) + abs(q0y)) * (abs(q1x) + abs(q1y)):
        return 0.0, np.inf
    if cross > 0.0:  # counter-clockwise from end 0 to end 1 is the short way round
        start, end = _fast_angle(q0x, q0y), _fast_angle(q1x, q1y)
    else:
        start, end = _fast_angle(q1x, q1y), _fast_angle(q0x, q0y)
    arc = end - start
    if arc < 0.0:
        arc += 2.0 * math.pi
    first = (start - angle_min) * inverse_step
    while first < 0.0:  # into [0, turn): at most once for a fan starting within a turn of the angle -pi
        first += turn
    while first >= turn:
        first -= turn
    margin = _ARC_MARGIN * inverse_step
    return first - margin, first + arc * inverse_step + margin


@njit(cache=True, nogil=True, error_model="numpy")
def _sector_maxima(ranges, sectors, first, last):  # noqa: ANN001, ANN202
    """sectors[k] for the sectors holding beams first..last: the largest of their ranges."""
    for k in range(first // SECTOR_BEAMS, last // SECTOR_BEAMS + 1):
        top = -np.inf
        for b in range(k * SECTOR_BEAMS, min((k + 1) * SECTOR_BEAMS, len(ranges))):
            top = max(top, ranges[b])
        sectors[k] = top


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _run_hidden(tx, ty, radius, p00, p01, p10, p11, stretch, angle_min, inverse_step, count, turn, sectors):  # noqa: ANN001, ANN202
    """Whether every sector the circle (offset tx, ty from the origin, `radius`) may span holds no range above
    the circle's nearest distance (beam plane): then no wall inside it can lower a beam."""
    qx, qy = p00 * tx + p01 * ty, p10 * tx + p11 * ty
    d = math.sqrt(qx * qx + qy * qy)
    r = radius * stretch
    if not d > 2.0 * r:  # near or around the origin: its arc is wide, test its walls one by one
        return False
    near = (d - r) * (1.0 - 1e-6) - 1e-9  # below any wall's nearest in it, rounding of both included
    half = (r / d) * (0.5 * math.pi)  # >= asin(r / d)
    first = (_fast_angle(qx, qy) - half - angle_min) * inverse_step
    while first < 0.0:
        first += turn
    while first >= turn:
        first -= turn
    margin = _ARC_MARGIN * inverse_step
    start, end = first - margin, first + 2.0 * half * inverse_step + margin
    shift = -turn
    while start + shift <= count - 1:
        a, b = max(start + shift, 0.0), min(end + shift, count - 1.0)
        if a <= b:
            for k in range(int(a) // SECTOR_BEAMS, int(b) // SECTOR_BEAMS + 1):
                if not sectors[k] <= near:
                    return False
        shift += turn
    return True


@njit(cache=True, nogil=True, error_model="numpy")
def _cast(table, ox, oy, oz, p00, p01, p10, p11, rz0, rz1, lo, hi, tilted, angle_min, inverse_step, count, turn,
          range_min, dirs, ranges, cull):  # noqa: ANN001, ANN202
    """cast_walls' loop, the frame given as numbers. A wall is cast if within reach, in the band (covering it, or
    with its heights if `tilted`) and facing the origin (a ray from outside a convex solid enters through an edge
    facing it; one starting inside, within range_min of it, leaves through the far side). If `cull`, a wall
    hidden behind nearer hits is dropped first (the module doc). One function with the walls' loop inside:
    a call per wall passing arrays would cost more than most walls' arithmetic (numba counts references)."""
    sectors = np.empty((count + SECTOR_BEAMS - 1) // SECTOR_BEAMS)
    stretch = 1.0
    if cull:
        _sector_maxima(ranges, sectors, 0, count - 1)
        squares, det = p00 * p00 + p01 * p01 + p10 * p10 + p11 * p11, p00 * p11 - p01 * p10
        stretch = math.sqrt(0.5 * (squares + math.sqrt(max(squares * squares - 4.0 * det * det, 0.0))))
        stretch = stretch * (1.0 + 1e-9) + 1e-12  # the largest singular value of to_plane, rounded up
    seen = np.empty(table.shape[1], np.intp)
    run_end = 0
    while run_end < table.shape[1]:
        run, run_end = run_end, int(table[RUN_END, run_end])
        if cull and _run_hidden(table[RUN_X, run] - ox, table[RUN_Y, run] - oy, table[RUN_R, run], p00, p01, p10,
                                p11, stretch, angle_min, inverse_step, count, turn, sectors):
            continue
        # the walls seen, listed first without a branch per wall (whether a wall is seen is hard to predict)
        n = 0
        for w in range(run, run_end):
            dx, dy = table[MIDX, w] - ox, table[MIDY, w] - oy
            zlo, zhi = table[ZLO, w], table[ZHI, w]
            cx, cy = table[CX, w] - ox, table[CY, w] - oy
            seen[n] = w
            n += ((dx * dx + dy * dy <= table[REACH2, w])
                  & ((zlo <= lo) & (zhi >= hi) | tilted & (zlo < hi) & (zhi > lo))
                  & ((table[CROSS, w] - ox * table[EY, w] + oy * table[EX, w] < 0.0)
                     | (cx * cx + cy * cy <= table[CREACH2, w]) | (table[TWO_SIDED, w] > 0.0)))
        for i in range(n):
            w = seen[i]
            zlo, zhi = table[ZLO, w], table[ZHI, w]
            spans = not (zlo <= lo and zhi >= hi)
            rx0, ry0 = table[X0, w] - ox, table[Y0, w] - oy
            rx1, ry1 = table[X1, w] - ox, table[Y1, w] - oy
            q0x, q0y = p00 * rx0 + p01 * ry0, p10 * rx0 + p11 * ry0
            q1x, q1y = p00 * rx1 + p01 * ry1, p10 * rx1 + p11 * ry1
            cross = q0x * q1y - q0y * q1x
            ex, ey = q1x - q0x, q1y - q0y
            # no hit on the wall is nearer than its nearest point: a beam already that near needs no division (walls
            # come roughly near to far, see grid.Cell, so in a map most beams of most walls are settled by this)
            along = -(q0x * ex + q0y * ey) / (ex * ex + ey * ey)
            along = min(max(along, 0.0), 1.0)
            nx, ny = q0x + along * ex, q0y + along * ey
            if cull:
                # hidden if every sector it may span holds no range above its nearest point; squared, with a margin
                # (4e-9) over nearest's (1e-9 below) that dwarfs the rounding of hypot against a square root
                near2 = (nx * nx + ny * ny) * (1.0 - 4e-9)
                start, end = _arc(q0x, q0y, q1x, q1y, cross, angle_min, inverse_step, turn)
                hidden = True
                shift = -turn  # the arc once round each way: the parts of it on beams of the fan
                while hidden and start + shift <= count - 1:
                    a, b = max(start + shift, 0.0), min(end + shift, count - 1.0)
                    if a <= b:
                        for k in range(int(a) // SECTOR_BEAMS, int(b) // SECTOR_BEAMS + 1):
                            top = sectors[k]
                            if not (top >= 0.0 and top * top <= near2):
                                hidden = False
                                break
                    shift += turn
                if not hidden and end - start < SECTOR_BEAMS:  # a short arc: its beams one by one
                    hidden = True
                    shift = -turn
                    while hidden and start + shift <= count - 1:
                        a, b = max(start + shift, 0.0), min(end + shift, count - 1.0)
                        for k in range(math.ceil(a), int(b) + 1):
                            top = ranges[k]
                            if not (top >= 0.0 and top * top <= near2):
                                hidden = False
                                break
                        shift += turn
                if hidden:
                    continue
            nearest = math.hypot(nx, ny) * (1.0 - 1e-9)
            a0 = (math.atan2(q0y, q0x) - angle_min) * inverse_step
            a1 = (math.atan2(q1y, q1x) - angle_min) * inverse_step
            first, last = min(a0, a1), max(a0, a1)
            if last - first > 0.5 * turn:  # the short way round goes through the gap behind the fan
                first, last = last, first + turn
            for part in range(2):
                if part == 0:
                    b0, b1 = max(math.ceil(first - INDEX_SLACK), 0), min(math.floor(last + INDEX_SLACK), count - 1)
                else:  # the part of the interval running past a full turn, onto the first beams
                    if last + INDEX_SLACK < turn:
                        break
                    b0, b1 = 0, min(math.floor(last - turn + INDEX_SLACK), count - 1)
                low, high = count, -1
                for b in range(b0, b1 + 1):
                    if ranges[b] <= nearest:
                        continue
                    t = cross / (dirs[0, b] * ey - dirs[1, b] * ex)
                    if t >= range_min and t < ranges[b]:
                        if spans:
                            z = oz + t * (rz0 * dirs[0, b] + rz1 * dirs[1, b])
                            if z < zlo or z > zhi:
                                continue
                        ranges[b] = t
                        low, high = min(low, b), b
                if cull and high >= 0:
                    for k in range(low // SECTOR_BEAMS, high // SECTOR_BEAMS + 1):
                        top = -np.inf
                        for b in range(k * SECTOR_BEAMS, min((k + 1) * SECTOR_BEAMS, count)):
                            top = max(top, ranges[b])
                        sectors[k] = top


@njit(cache=True, nogil=True, error_model="numpy")
def cast_walls(table, origin, to_plane, rotation, lo, hi, tilted, angle_min, inverse_step, count, turn, range_min,
               dirs, ranges, cull=True):  # noqa: ANN001, ANN201
    """Lower `ranges` (count,) to one scan's first hits on the walls of `table` seen from `origin` (3,), in the
    band [lo, hi]. Walls covering only part of the band are cast (with their heights) only if `tilted`.
    `cull`: drop walls hidden behind nearer hits first (the ranges are the same either way)."""
    _cast(table, origin[0], origin[1], origin[2], to_plane[0, 0], to_plane[0, 1], to_plane[1, 0], to_plane[1, 1],
          rotation[2, 0], rotation[2, 1], lo, hi, tilted, angle_min, inverse_step, count, turn, range_min, dirs,
          ranges, cull)


@njit(cache=True, nogil=True, error_model="numpy")
def _cast_faces(table, polygon, poly_start, poly_edges, marked, origin, rotation, lo, hi, range_min, dirs, ranges):  # noqa: ANN001, ANN202
    """Lower `ranges` to the hits on the top and bottom faces of the marked polygons (box footprints, edges
    counter-clockwise): only a face inside the band and facing the origin can be the first hit."""
    ox, oy, oz = origin[0], origin[1], origin[2]
    for k in range(len(marked)):
        if not marked[k]:
            continue
        e0 = poly_edges[poly_start[k]]
        for face in range(2):
            height = table[ZLO, e0] if face == 0 else table[ZHI, e0]
            if face == 0 and not (oz <= height <= hi):
                continue
            if face == 1 and not (lo <= height <= oz):
                continue
            for b in range(dirs.shape[1]):
                u0, u1 = dirs[0, b], dirs[1, b]
                t = (height - oz) / (rotation[2, 0] * u0 + rotation[2, 1] * u1)
                if not (t >= range_min and t < ranges[b]):
                    continue
                px = ox + t * (rotation[0, 0] * u0 + rotation[0, 1] * u1)
                py = oy + t * (rotation[1, 0] * u0 + rotation[1, 1] * u1)
                inside = True
                for i in range(poly_start[k], poly_start[k + 1]):
                    e = poly_edges[i]
                    if table[EX, e] * (py - table[Y0, e]) - table[EY, e] * (px - table[X0, e]) < 0.0:
                        inside = False
                        break
                if inside:
                    ranges[b] = t


@njit(cache=True, nogil=True, error_model="numpy")
def cast_batch(table, polygon, poly_start, poly_edges, floors, others, origins, to_plane, rotations, bands, steep,
               angle_min, inverse_step, count, turn, range_min, range_max, dirs, ranges, fallback):  # noqa: ANN001, ANN201
    """batch.BatchWallCaster's cast for worlds i (rows of origins, ...): ranges[i] lowered to its scan's hits
    on the walls and box faces, or fallback[i] set where the 2-D cast cannot answer (see batch.py)."""
    marked = np.zeros(len(poly_start) - 1, np.bool_)
    for i in range(origins.shape[0]):
        ox, oy = origins[i, 0], origins[i, 1]
        lo, hi = bands[i, 0], bands[i, 1]
        fall = steep[i]
        for z in floors:
            if lo <= z <= hi:
                fall = True
        for j in range(others.shape[1]):
            reach = others[2, j] + range_max
            dx, dy = others[0, j] - ox, others[1, j] - oy
            if math.sqrt(dx * dx + dy * dy) <= reach and others[3, j] < hi and others[4, j] > lo:
                fall = True
        # walls covering part of the band: exact when they are edges of boxes (a side counts at the heights the
        # box spans; the beams may also meet its top or bottom face); a partly covering two-sided wall falls back
        tilted = False
        marked[:] = False
        if not fall:
            for w in range(table.shape[1]):
                zlo, zhi = table[ZLO, w], table[ZHI, w]
                if (zlo <= lo and zhi >= hi) or not (zlo < hi and zhi > lo):
                    continue
                dx, dy = table[MIDX, w] - ox, table[MIDY, w] - oy
                if dx * dx + dy * dy > table[REACH2, w]:
                    continue
                if table[TWO_SIDED, w] > 0.0:
                    fall = True
                    break
                tilted = True
                marked[polygon[w]] = True
        fallback[i] = fall
        if fall:
            continue
        cast_walls(table, origins[i], to_plane[i], rotations[i], lo, hi, tilted, angle_min, inverse_step, count,
                   turn, range_min, dirs, ranges[i])
        if tilted:
            _cast_faces(table, polygon, poly_start, poly_edges, marked, origins[i], rotations[i], lo, hi, range_min,
                        dirs, ranges[i])
        for b in range(count):
            if ranges[i, b] > range_max:
                ranges[i, b] = np.inf


@njit(cache=True, nogil=True, error_model="numpy")
def cast_level(table, floors, origin, rotation, max_tilt_cos, angle_min, inverse_step, count, turn, range_min,
               range_max, dirs, ranges, cull=True):  # noqa: ANN001, ANN201
    """RayCaster.cast's common case in one call: a scan of prisms that all cover its height band. Lowers
    `ranges` (count,) to the first hits on the walls of `table`, range_max applied, and returns True; or returns
    False, `ranges` untouched, when the scan needs the general path (a steep scan plane, a floor in the band, a
    wall within reach covering only part of the band). The frame is ScanFrame's, computed here. `cull`: as
    cast_walls'."""
    e1x, e2x, e1y, e2y = rotation[0, 0], rotation[0, 1], rotation[1, 0], rotation[1, 1]
    det = e1x * e2y - e2x * e1y
    if det < max_tilt_cos:
        return False
    half = range_max * math.hypot(rotation[2, 0], rotation[2, 1]) * (1.0 + 1e-12) + 1e-12
    ox, oy, oz = origin[0], origin[1], origin[2]
    lo, hi = oz - half, oz + half
    for z in floors:
        if lo <= z <= hi:
            return False
    n = table.shape[1]
    if n and not (table[ZLO_MAX, 0] <= lo and table[ZHI_MIN, 0] >= hi):  # some wall may cover part of the band
        for w in range(n):
            zlo, zhi = table[ZLO, w], table[ZHI, w]
            if not (zlo <= lo and zhi >= hi) and zlo < hi and zhi > lo:
                dx, dy = table[MIDX, w] - ox, table[MIDY, w] - oy
                if dx * dx + dy * dy <= table[REACH2, w]:
                    return False
    _cast(table, ox, oy, oz, e2y / det, -e2x / det, -e1y / det, e1x / det, 0.0, 0.0, lo, hi, False, angle_min,
          inverse_step, count, turn, range_min, dirs, ranges, cull)
    for b in range(count):
        if ranges[b] > range_max:
            ranges[b] = np.inf
    return True
