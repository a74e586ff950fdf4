"""The 2-D wall cast compiled (numba): planar.cast_segments' formulas as loops, one scan or a batch of scans.

numpy's cost in the wall cast is per call, not per element (~40 array operations and their temporaries per
scan: tens of microseconds for a scan that is a few thousand multiply-adds). Here a scan is one call: each
wall is culled (out of reach, facing away, outside the height band), its beam interval found from the angles
of its ends, and those beams intersected with it, in place on the ranges. The kernels release the GIL, so a
batch's worlds are cast on the physics threads.

A wall table has one column per wall (segment), rows WALL_ROWS (see wall_table). The results are those of
the numpy code beam for beam, to the last bit of t: the same operations in the same order (no fast-math).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from numpy.typing import NDArray

from racecar_sim.sensors.raycast.fan import INDEX_SLACK

# rows of a wall table
X0, Y0, X1, Y1, ZLO, ZHI, MIDX, MIDY, REACH2, CX, CY, CREACH2, CROSS, EX, EY, TWO_SIDED = range(16)
WALL_ROWS = 16
_CULL_SLACK = 1.0 + 1e-9  # the reach tests only cull: a wall kept too many changes no range
# the kernels' arrays: tables, poses, directions and ranges (float64), polygon numbers and columns (intp), flags
Floats = NDArray[np.float64]
Indices = NDArray[np.intp]
Flags = NDArray[np.bool_]
# a fan as the kernels pass it on: (angle_min, inverse_step, count, turn) (fan.Fan's fields)
Beams = tuple[float, float, int, float]
# ScanFrame.to_plane's entries (p00, p01, p10, p11): horizontal offsets into the beam plane
Plane = tuple[float, float, float, float]


def wall_table(segments: np.ndarray, range_min: float, range_max: float) -> np.ndarray:
    """The kernels' table (WALL_ROWS, n) of a scene.py segment table (13, n)."""
    x0, y0, x1, y1 = segments[:4]
    return np.ascontiguousarray(
        np.array(
            [
                x0,
                y0,
                x1,
                y1,
                segments[4],
                segments[5],
                segments[6],
                segments[7],
                ((segments[8] + range_max) * _CULL_SLACK)
                ** 2,  # a wall's points lie within half its length of its middle
                segments[9],
                segments[10],
                ((segments[11] + range_min) * _CULL_SLACK) ** 2,
                x0 * y1 - y0 * x1,
                x1 - x0,
                y1 - y0,
                (segments[12] == 0).astype(float),
            ]
        ).reshape(WALL_ROWS, -1)
    )


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def within_reach(table: Floats, w: int, ox: float, oy: float) -> bool:
    """Whether a beam from (ox, oy) may reach wall w (its middle within half its length plus range_max)."""
    dx, dy = table[MIDX, w] - ox, table[MIDY, w] - oy
    return dx * dx + dy * dy <= table[REACH2, w]


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def facing(table: Floats, w: int, ox: float, oy: float) -> bool:
    """Whether wall w may be a first hit from (ox, oy): a ray from outside a convex solid enters through an edge
    facing it (the origin on its outer side); one starting inside (within range_min of it) leaves through the far
    side; a two-sided wall faces both ways."""
    cx, cy = table[CX, w] - ox, table[CY, w] - oy
    return (
        (table[CROSS, w] - ox * table[EY, w] + oy * table[EX, w] < 0.0)
        | (cx * cx + cy * cy <= table[CREACH2, w])
        | (table[TWO_SIDED, w] > 0.0)
    )


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def partly_within(table: Floats, w: int, lo: float, hi: float) -> bool:
    """Whether wall w covers part of the band [lo, hi], not all of it."""
    zlo, zhi = table[ZLO, w], table[ZHI, w]
    return not (zlo <= lo and zhi >= hi) and zlo < hi and zhi > lo


@njit(cache=True, nogil=True, error_model="numpy")
def _wall_is_seen(table: Floats, w: int, ox: float, oy: float, lo: float, hi: float, tilted: bool) -> int:
    """0: culled; 1: cast, the wall covers the band; 2: cast, a hit counts only at the heights it spans."""
    if not within_reach(table, w, ox, oy):
        return 0
    zlo, zhi = table[ZLO, w], table[ZHI, w]
    covers = zlo <= lo and zhi >= hi
    if not covers and not (tilted and zlo < hi and zhi > lo):
        return 0
    if not facing(table, w, ox, oy):
        return 0
    return 1 if covers else 2


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def in_plane(table: Floats, w: int, ox: float, oy: float, plane: Plane) -> tuple[float, float, float, float]:
    """The ends (q0x, q0y, q1x, q1y) of wall w in the beam plane, the origin (ox, oy) at 0."""
    p00, p01, p10, p11 = plane
    rx0, ry0 = table[X0, w] - ox, table[Y0, w] - oy
    rx1, ry1 = table[X1, w] - ox, table[Y1, w] - oy
    return p00 * rx0 + p01 * ry0, p10 * rx0 + p11 * ry0, p00 * rx1 + p01 * ry1, p10 * rx1 + p11 * ry1


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def nearest_point(q0x: float, q0y: float, ex: float, ey: float) -> tuple[float, float]:
    """The point of the segment from (q0x, q0y) along (ex, ey) nearest the origin."""
    along = -(q0x * ex + q0y * ey) / (ex * ex + ey * ey)
    along = min(max(along, 0.0), 1.0)
    return q0x + along * ex, q0y + along * ey


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def beam_range(lo: float, hi: float, count: int, turn: float, part: int) -> tuple[int, int]:
    """planar._intervals: the beams (first, last; first > last: none) of fan positions lo..hi, part 0, or of their
    part past a full turn (onto the first beams), part 1."""
    if part == 0:
        return max(math.ceil(lo - INDEX_SLACK), 0), min(math.floor(hi + INDEX_SLACK), count - 1)
    if hi + INDEX_SLACK < turn:
        return 0, -1
    return 0, min(math.floor(hi - turn + INDEX_SLACK), count - 1)


@njit(cache=True, nogil=True, error_model="numpy")
def hit_wall(
    table: Floats,
    w: int,
    spans: bool,
    ox: float,
    oy: float,
    oz: float,
    plane: Plane,
    rz: tuple[float, float],
    beams: Beams,
    range_min: float,
    dirs: Floats,
    ranges: Floats,
) -> None:
    """Lower `ranges` to the beams' hits on wall w (spans: only where the hit lies within its heights, the beam
    directions' world z being rz . dirs)."""
    angle_min, inverse_step, count, turn = beams
    q0x, q0y, q1x, q1y = in_plane(table, w, ox, oy, plane)
    a0 = (math.atan2(q0y, q0x) - angle_min) * inverse_step
    a1 = (math.atan2(q1y, q1x) - angle_min) * inverse_step
    lo, hi = min(a0, a1), max(a0, a1)
    if hi - lo > 0.5 * turn:  # the short way round goes through the gap behind the fan
        lo, hi = hi, lo + turn
    cross = q0x * q1y - q0y * q1x
    ex, ey = q1x - q0x, q1y - q0y
    # no hit on the wall is nearer than its nearest point: a beam already that near needs no division (walls
    # come roughly near to far, see grid.Cell, so in a map most beams of most walls are settled by this)
    nearest = math.hypot(*nearest_point(q0x, q0y, ex, ey)) * (1.0 - 1e-9)
    zlo, zhi = table[ZLO, w], table[ZHI, w]
    for part in range(2):
        first, last = beam_range(lo, hi, count, turn, part)
        for b in range(first, last + 1):
            if ranges[b] <= nearest:
                continue
            t = cross / (dirs[0, b] * ey - dirs[1, b] * ex)
            if t >= range_min and t < ranges[b]:
                if spans:
                    z = oz + t * (rz[0] * dirs[0, b] + rz[1] * dirs[1, b])
                    if z < zlo or z > zhi:
                        continue
                ranges[b] = t


@njit(cache=True, nogil=True, error_model="numpy")
def walls_in_band(
    table: Floats,
    ox: float,
    oy: float,
    oz: float,
    plane: Plane,
    rz: tuple[float, float],
    lo: float,
    hi: float,
    tilted: bool,
    beams: Beams,
    range_min: float,
    dirs: Floats,
    ranges: Floats,
) -> None:
    """cast_walls from (ox, oy, oz), the plane map and the world z of the beam axes (rz) given."""
    for w in range(table.shape[1]):
        seen = _wall_is_seen(table, w, ox, oy, lo, hi, tilted)
        if seen:
            hit_wall(table, w, seen == 2, ox, oy, oz, plane, rz, beams, range_min, dirs, ranges)


@njit(cache=True, nogil=True, error_model="numpy")
def cast_walls(
    table: Floats,
    origin: Floats,
    to_plane: Floats,
    rotation: Floats,
    lo: float,
    hi: float,
    tilted: bool,
    angle_min: float,
    inverse_step: float,
    count: int,
    turn: float,
    range_min: float,
    dirs: Floats,
    ranges: Floats,
) -> None:
    """Lower `ranges` (count,) to one scan's first hits on the walls of `table` seen from `origin` (3,), in the
    band [lo, hi]. Walls covering only part of the band are cast (with their heights) only if `tilted`."""
    plane = (to_plane[0, 0], to_plane[0, 1], to_plane[1, 0], to_plane[1, 1])
    rz = (rotation[2, 0], rotation[2, 1])
    beams = (angle_min, inverse_step, count, turn)
    walls_in_band(table, origin[0], origin[1], origin[2], plane, rz, lo, hi, tilted, beams, range_min, dirs, ranges)


@njit(cache=True, nogil=True, error_model="numpy")
def _cast_faces(
    table: Floats,
    poly_start: Indices,
    poly_edges: Indices,
    marked: Flags,
    origin: Floats,
    rotation: Floats,
    lo: float,
    hi: float,
    range_min: float,
    dirs: Floats,
    ranges: Floats,
) -> None:
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


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def clear_past(ranges: Floats, range_max: float) -> None:
    """inf for the ranges past range_max (nothing hit within it)."""
    for b in range(ranges.shape[0]):
        if ranges[b] > range_max:
            ranges[b] = np.inf


@njit(cache=True, nogil=True, error_model="numpy")
def cast_batch(
    table: Floats,
    polygon: Indices,
    poly_start: Indices,
    poly_edges: Indices,
    floors: Floats,
    others: Floats,
    origins: Floats,
    to_plane: Floats,
    rotations: Floats,
    bands: Floats,
    steep: Flags,
    angle_min: float,
    inverse_step: float,
    count: int,
    turn: float,
    range_min: float,
    range_max: float,
    dirs: Floats,
    ranges: Floats,
    fallback: Flags,
) -> None:
    """batch.BatchWallCaster's cast for worlds i (rows of origins, ...): ranges[i] lowered to its scan's hits
    on the walls and box faces, or fallback[i] set where the 2-D cast cannot answer (see batch.py)."""
    marked = np.zeros(len(poly_start) - 1, np.bool_)
    beams = (angle_min, inverse_step, count, turn)
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
                if not partly_within(table, w, lo, hi) or not within_reach(table, w, ox, oy):
                    continue
                if table[TWO_SIDED, w] > 0.0:
                    fall = True
                    break
                tilted = True
                marked[polygon[w]] = True
        fallback[i] = fall
        if fall:
            continue
        square, axes = to_plane[i], rotations[i]
        plane, rz = (square[0, 0], square[0, 1], square[1, 0], square[1, 1]), (axes[2, 0], axes[2, 1])
        walls_in_band(table, ox, oy, origins[i, 2], plane, rz, lo, hi, tilted, beams, range_min, dirs, ranges[i])
        if tilted:
            _cast_faces(
                table, poly_start, poly_edges, marked, origins[i], rotations[i], lo, hi, range_min, dirs, ranges[i]
            )
        clear_past(ranges[i], range_max)


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def level_band(
    floors: Floats, origin: Floats, rotation: Floats, max_tilt_cos: float, range_max: float
) -> tuple[bool, float, float]:
    """(level, lo, hi): the height band [lo, hi] of a scan from `origin` with axes `rotation`, and whether the 2-D
    cast answers it alone (not a steep scan plane, no floor in the band)."""
    det = rotation[0, 0] * rotation[1, 1] - rotation[0, 1] * rotation[1, 0]
    half = range_max * math.hypot(rotation[2, 0], rotation[2, 1]) * (1.0 + 1e-12) + 1e-12
    lo, hi = origin[2] - half, origin[2] + half
    level = det >= max_tilt_cos
    for z in floors:
        if lo <= z <= hi:
            level = False
    return level, lo, hi


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def plane_map(rotation: Floats) -> tuple[Plane, float]:
    """ScanFrame.to_plane of a scan with axes `rotation` (world from sensor), and its inverse's determinant (the
    cosine of the tilt)."""
    e1x, e2x, e1y, e2y = rotation[0, 0], rotation[0, 1], rotation[1, 0], rotation[1, 1]
    det = e1x * e2y - e2x * e1y
    return (e2y / det, -e2x / det, -e1y / det, e1x / det), det


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def stretch_of(plane: Plane, det: float) -> float:
    """The largest singular value of the plane map (plane_map's pair): how much it may lengthen an offset."""
    p00, p01, p10, p11 = plane
    squares = p00 * p00 + p01 * p01 + p10 * p10 + p11 * p11
    inverse_det = 1.0 / det
    return math.sqrt(0.5 * (squares + math.sqrt(max(squares * squares - 4.0 * inverse_det * inverse_det, 0.0))))


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def partly_covered(table: Floats, ox: float, oy: float, lo: float, hi: float) -> bool:
    """Whether a wall of `table` within reach of (ox, oy) covers only part of [lo, hi]."""
    for w in range(table.shape[1]):
        if partly_within(table, w, lo, hi) and within_reach(table, w, ox, oy):
            return True
    return False
