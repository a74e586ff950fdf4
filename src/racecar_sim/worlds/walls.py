"""Wall geometry shared by occupancy maps and race tracks: few boxes, so physics, ray casts and rendering stay fast.

Occupied grid cells are merged into non-overlapping rectangles; a track border becomes one box per segment
of its simplified polyline, the box's inner face exactly on the line.
"""

from __future__ import annotations

from typing import Literal

import numpy as np

from racecar_sim.core.transforms import quat_from_axis_angle
from racecar_sim.worlds.world import WorldGeom

WALL_RGBA = (0.6, 0.6, 0.6, 1.0)
MAX_MITER = 4.0  # tan(half turn) cap: a spike sharper than ~150 degrees gets a 4-thickness extension
OVERLAP = 1e-4  # m, boxes meeting at a convex corner overlap by this much, so no ray slips between them
FILLER = 0.002  # m, thickness of the boxes that carry an inner face into a sharp corner (their largest poke)
Z_AXIS = (0.0, 0.0, 1.0)


def cell_rectangles(occupied: np.ndarray) -> list[tuple[int, int, int, int]]:
    """Rectangles (row0, col0, row1, col1), half-open, covering exactly the True cells without overlap.

    Greedy: the first cell not yet covered (row-major) is the top-left corner of the next rectangle, the larger of
    the widest-then-tallest and the tallest-then-widest one of uncovered cells from there. A solid block is one
    rectangle, a room's outline four; a scanned map's walls, one cell thick and drawn in steps where they run
    askew, come out at about a fifth of their cells (the MIT basement's 11,182 cells: 2,225 boxes).
    """
    grid = np.asarray(occupied, dtype=bool)
    if grid.ndim != 2:
        raise ValueError(f"occupied must be a 2-D array, got shape {grid.shape}")
    todo = grid.copy()
    rects = []
    for r in np.flatnonzero(grid.any(axis=1)).tolist():
        row = todo[r]
        while row.any():
            c = int(row.argmax())
            width = _run(row[c:])
            wide = (width, _run(todo[r:, c : c + width].all(axis=1)))
            height = _run(todo[r:, c])
            tall = (_run(todo[r : r + height, c:].all(axis=0)), height)
            w, h = wide if wide[0] * wide[1] >= tall[0] * tall[1] else tall
            todo[r : r + h, c : c + w] = False
            rects.append((r, c, r + h, c + w))
    return rects


def _run(cells: np.ndarray) -> int:
    """How many leading entries of a 1-D boolean array are True."""
    first_false = int(cells.argmin())
    return len(cells) if cells[first_false] else first_false


def box_geoms(
    name: str,
    centers: np.ndarray,
    sizes: np.ndarray,
    yaws: np.ndarray,
    rgba: tuple[float, float, float, float] = WALL_RGBA,
    mu: float = 1.0,
) -> list[WorldGeom]:
    """A collision box and its visual copy (collision geoms are hidden in rendering) per row of centers/sizes/yaws.

    centers (N, 3) and sizes (N, 3, full extents) in metres, yaws (N,) in radians about z.
    """
    geoms = []
    for i, (center, size, yaw) in enumerate(zip(np.asarray(centers, float), np.asarray(sizes, float), yaws)):
        quat = quat_from_axis_angle(Z_AXIS, float(yaw))
        extents = tuple(float(s) for s in size)
        geoms.append(WorldGeom(f"{name}_{i}", "box", extents, center.copy(), quat, collides=True, mu=mu, mu2=mu))
        geoms.append(
            WorldGeom(f"{name}_{i}_visual", "box", extents, center.copy(), quat.copy(), collides=False, rgba=rgba)
        )
    return geoms


def _segments(points: np.ndarray, closed: bool) -> tuple[np.ndarray, np.ndarray]:
    """Start and end points of each segment of a polyline."""
    end = np.roll(points, -1, axis=0) if closed else points[1:]
    return (points if closed else points[:-1]), end


def border_walls(
    border: np.ndarray,
    closed: bool,
    outward: Literal["left", "right"],
    thickness: float,
    height: float,
    z0: float = 0.0,
    name: str = "wall",
    rgba: tuple[float, float, float, float] = WALL_RGBA,
    mu: float = 1.0,
) -> list[WorldGeom]:
    """Box walls along a polyline (N, 2): inner face on the line, body on the `outward` side of its direction.

    At a corner that turns away from the wall both boxes run on to the miter line (plus OVERLAP), so the
    outer wedge is filled. At a corner that turns into the wall they overlap and stop at the vertex; past
    90 degrees a full box would poke through the other's inner face, so both stop t |cot(turn)| short and a
    FILLER-thin box carries each inner face on to the vertex. Returns collision boxes and their visual copies.
    """
    if outward not in ("left", "right"):
        raise ValueError(f"outward must be 'left' or 'right', got {outward!r}")
    start, end = _segments(np.asarray(border, dtype=float), closed)
    delta = end - start
    length = np.hypot(delta[:, 0], delta[:, 1])
    if np.any(length <= 0):
        raise ValueError(f"{name}: polyline has repeated consecutive points")
    direction = delta / length[:, None]
    side = 1.0 if outward == "left" else -1.0
    normal = side * np.c_[-direction[:, 1], direction[:, 0]]  # unit, pointing into the wall
    before, after = _corner_extensions(direction, length, closed, side, thickness)
    faces = [(start - before[:, None] * direction, end + after[:, None] * direction, normal, thickness)]
    cut = before < 0
    faces.append((start[cut], start[cut] - (before[cut, None] - OVERLAP) * direction[cut], normal[cut], FILLER))
    cut = after < 0
    faces.append((end[cut] + (after[cut, None] - OVERLAP) * direction[cut], end[cut], normal[cut], FILLER))
    geoms = []
    for label, (a, b, n, depth) in zip((name, f"{name}_corner_start", f"{name}_corner_end"), faces):
        if len(a):
            geoms += _face_boxes(label, a, b, n, depth, z0, height, rgba, mu)
    return geoms


def _face_boxes(
    name: str,
    a: np.ndarray,
    b: np.ndarray,
    normal: np.ndarray,
    depth: float,
    z0: float,
    height: float,
    rgba: tuple[float, float, float, float],
    mu: float,
) -> list[WorldGeom]:
    """Boxes whose inner face runs from a to b (each (N, 2)), `depth` metres deep along `normal`."""
    delta = b - a
    centers = np.c_[0.5 * (a + b) + 0.5 * depth * normal, np.full(len(a), z0 + 0.5 * height)]
    sizes = np.c_[np.hypot(delta[:, 0], delta[:, 1]), np.full(len(a), depth), np.full(len(a), height)]
    return box_geoms(name, centers, sizes, np.arctan2(delta[:, 1], delta[:, 0]), rgba, mu)


def _corner_extensions(
    direction: np.ndarray, length: np.ndarray, closed: bool, side: float, thickness: float
) -> tuple[np.ndarray, np.ndarray]:
    """How far each segment's box runs on past its start and its end vertex (metres; negative: stops short)."""
    if closed:
        incoming, outgoing = np.roll(direction, 1, axis=0), direction
        shortest = np.minimum(np.roll(length, 1), length)
    else:
        incoming, outgoing = direction[:-1], direction[1:]
        shortest = np.minimum(length[:-1], length[1:])
    cross = incoming[:, 0] * outgoing[:, 1] - incoming[:, 1] * outgoing[:, 0]
    turn = np.arctan2(cross, np.einsum("ij,ij->i", incoming, outgoing))  # > 0: turns left
    bend = np.abs(turn)
    convex = side * turn < 0  # turns away from the wall's side
    miter = thickness * np.minimum(np.tan(0.5 * bend), MAX_MITER) + OVERLAP
    # turning into the wall by more than 90 degrees, a box running to the vertex would poke through the other's
    # inner face: it stops t |cot| short (at most a quarter of the shorter segment, so a box always remains)
    sharp = np.minimum(thickness / np.tan(np.maximum(bend, 1e-9)), 0.0)
    vertex = np.where(convex, miter, np.maximum(sharp, -0.25 * shortest))
    if closed:  # vertex i joins segment i-1 (its end) to segment i (its start)
        return vertex, np.roll(vertex, -1)
    return np.r_[0.0, vertex], np.r_[vertex, 0.0]


def simplify(polyline: np.ndarray, tolerance: float, closed: bool = False) -> np.ndarray:
    """Douglas–Peucker: the fewest vertices of `polyline` (N, 2) within `tolerance` metres of every point.

    A closed polyline is split at its first point and the point farthest from it, so both are kept.
    """
    points = np.asarray(polyline, dtype=float)
    if len(points) < 3:
        return points.copy()
    if closed:
        far = int(np.argmax(np.hypot(*(points - points[0]).T)))
        if far == 0:
            return points[:1].copy()
        ring = np.r_[points, points[:1]]
        keep = np.r_[
            _douglas_peucker(ring[: far + 1], tolerance)[:-1], far + _douglas_peucker(ring[far:], tolerance)[:-1]
        ]
        return points[keep]
    return points[_douglas_peucker(points, tolerance)]


def _douglas_peucker(points: np.ndarray, tolerance: float) -> np.ndarray:
    """Indices kept from an open polyline, first and last included, in order."""
    keep = np.zeros(len(points), dtype=bool)
    keep[[0, -1]] = True
    stack = [(0, len(points) - 1)]
    while stack:
        i, j = stack.pop()
        if j - i < 2:
            continue
        inner = points[i + 1 : j]
        distance = _distance_to_segment(inner, points[i], points[j])
        k = int(np.argmax(distance))
        if distance[k] > tolerance:
            keep[i + 1 + k] = True
            stack += [(i, i + 1 + k), (i + 1 + k, j)]
    return np.flatnonzero(keep)


def _distance_to_segment(points: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Distance of each point to the segment a-b."""
    ab = b - a
    denom = float(ab @ ab)
    t = np.zeros(len(points)) if denom == 0 else np.clip((points - a) @ ab / denom, 0.0, 1.0)
    return np.hypot(*(points - a - t[:, None] * ab).T)


def left_normals(points: np.ndarray, closed: bool) -> np.ndarray:
    """Unit normals (N, 2) to the left of a polyline's direction, averaged over the two segments at each vertex."""
    points = np.asarray(points, dtype=float)
    start, end = _segments(points, closed)
    delta = end - start
    direction = delta / np.hypot(delta[:, 0], delta[:, 1])[:, None]
    segment_normal = np.c_[-direction[:, 1], direction[:, 0]]
    if closed:
        summed = segment_normal + np.roll(segment_normal, 1, axis=0)
    else:
        summed = np.r_[segment_normal[:1], segment_normal[1:] + segment_normal[:-1], segment_normal[-1:]]
    norm = np.hypot(summed[:, 0], summed[:, 1])
    if np.any(norm < 1e-12):
        raise ValueError("polyline doubles back on itself: no normal at a vertex")
    return summed / norm[:, None]


def offset_polyline(
    points: np.ndarray, distances: np.ndarray | float, side: Literal["left", "right"], closed: bool
) -> np.ndarray:
    """Each vertex moved to `side` so that the offset segments lie `distances` metres (scalar or per point) from
    the polyline's own: along the averaged normal, lengthened by 1 / cos(half the turn), as a miter joint.

    At a 90-degree corner of a 2 m wide road the border corner is sqrt(2) m from the centre line's corner, and
    each border segment runs parallel to its centre segment at 1 m. Sharp spikes are capped at MAX_MITER.
    """
    if side not in ("left", "right"):
        raise ValueError(f"side must be 'left' or 'right', got {side!r}")
    points = np.asarray(points, dtype=float)
    sign = 1.0 if side == "left" else -1.0
    d = np.broadcast_to(np.asarray(distances, dtype=float), (len(points),))
    normals = left_normals(points, closed)
    start, end = _segments(points, closed)
    delta = end - start
    segment_normal = np.c_[-delta[:, 1], delta[:, 0]] / np.hypot(delta[:, 0], delta[:, 1])[:, None]
    # the segment leaving each vertex (the one arriving, at an open polyline's last point)
    leaving = segment_normal if closed else np.r_[segment_normal, segment_normal[-1:]]
    cos_half = np.einsum("ij,ij->i", normals, leaving)
    scale = 1.0 / np.maximum(cos_half, 1.0 / MAX_MITER)
    return points + sign * (d * scale)[:, None] * normals
