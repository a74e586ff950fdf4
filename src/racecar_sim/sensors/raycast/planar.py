"""The 2-D caster: beams against exact footprints of vertical prisms, vectorised with numpy.

Each footprint is tested only by the beams inside its angular interval as seen from the sensor (polar
culling), so the work is proportional to the beam-footprint pairs that can hit, not beams x footprints.
Distances are 3-D distances along the (possibly tilted) beams, measured from the ray origin; a beam sees
the first surface at or beyond range_min, as a ray starting at range_min does (from inside a solid, that
is its far side, as MuJoCo's ray casts give it).

numpy's cost here is mostly per call, not per element, so the code keeps the number of array operations
per scan small (about forty for the segments) rather than the arithmetic.
"""

from __future__ import annotations

import math

import numpy as np

from racecar_sim.sensors.raycast.fan import INDEX_SLACK, Fan, ScanFrame


def _intervals(frame: ScanFrame, lo: np.ndarray, hi: np.ndarray, wraps: bool) -> tuple[np.ndarray, np.ndarray, bool]:
    """Beam intervals [first, last] for fan positions lo <= hi (in beam steps from the first beam; either may
    lie in the gap behind the fan). If `wraps`, intervals may run past a full turn onto the first beams: the
    arrays are then doubled, the second half holding those parts. Returns (first, last, doubled)."""
    fan = frame.fan
    first = np.maximum(np.ceil(lo - INDEX_SLACK), 0.0)  # positions below 0 are in the gap behind the fan
    last = np.minimum(np.floor(hi + INDEX_SLACK), fan.count - 1)
    if not wraps or hi.max() + INDEX_SLACK < fan.turn:
        return first, last, False
    wrapped = np.minimum(np.floor(hi - fan.turn + INDEX_SLACK), fan.count - 1)
    return np.concatenate([first, np.zeros_like(first)]), np.concatenate([last, wrapped]), True


def _pairs(first: np.ndarray, last: np.ndarray, per_item: np.ndarray, doubled: bool) -> tuple[np.ndarray, np.ndarray]:
    """Every (beam, item) pair inside the intervals: the beam indices, and `per_item`'s columns repeated."""
    counts = np.maximum(last - first + 1.0, 0.0).astype(np.intp)
    offsets = np.cumsum(counts)
    if doubled:
        per_item = np.concatenate([per_item, per_item], axis=1)
    beam = np.arange(offsets[-1]) + np.repeat(first.astype(np.intp) - offsets + counts, counts)
    return beam, np.repeat(per_item, counts, axis=1)


class Walls:
    """Segments (a scene.py segment table) prepared for casting: per scan, a wall out of reach or facing
    away is dropped with a few array operations before any beam is tested against it."""

    def __init__(self, segments: np.ndarray, fan: Fan) -> None:
        x0, y0, x1, y1 = segments[:4]
        # rows: ends | mid x, mid y, reach | footprint circle x, y, radius + range_min | constant and linear
        # parts of the ends' cross product about the origin | two-sided
        self.data = np.array([x0, y0, x1, y1, segments[6], segments[7], segments[8] + fan.range_max,
                              segments[9], segments[10], segments[11] + fan.range_min, x0 * y1 - y0 * x1,
                              x1 - x0, y1 - y0, 1.0 - segments[12]])
        self.count = segments.shape[1]
        self.two_sided = bool(np.any(segments[12] == 0))

    def cast(self, frame: ScanFrame, ranges: np.ndarray) -> None:
        """Lower `ranges` to the distance of each beam's first hit on these walls."""
        if self.count == 0:
            return
        x, y = frame.origin[0], frame.origin[1]
        d = np.compress(np.hypot(self.data[4] - x, self.data[5] - y) <= self.data[6], self.data, axis=1)
        # a ray from outside a convex solid enters through an edge facing it (the origin on its outer side,
        # cross < 0); one starting inside (within range_min of the origin) leaves through the far side
        facing = (d[10] - x * d[12] + y * d[11] < 0) | (np.hypot(d[7] - x, d[8] - y) <= d[9])
        if self.two_sided:
            facing |= d[13] > 0
        ends = np.compress(facing, d[:4], axis=1)
        if ends.shape[1]:
            cast_segments(frame, ends, ranges)


def cast_segments(frame: ScanFrame, ends: np.ndarray, ranges: np.ndarray) -> None:
    """Lower `ranges` to each beam's first hit on the segments (columns of rows x0, y0, x1, y1)."""
    fan = frame.fan
    n = ends.shape[1]
    q = frame.to_plane @ (ends.reshape(2, 2, n) - frame.origin[:2, None])  # [end][x|y][segment]
    pos = (np.arctan2(q[:, 1], q[:, 0]) - fan.angle_min) * fan.inverse_step  # in (-gap/2, count + gap/2)
    lo, hi = np.minimum(pos[0], pos[1]), np.maximum(pos[0], pos[1])
    behind = hi - lo > 0.5 * fan.turn  # the short way round goes through the gap behind the fan
    wraps = bool(behind.any())
    if wraps:
        lo, hi = np.where(behind, hi, lo), np.where(behind, lo + fan.turn, hi)
    first, last, doubled = _intervals(frame, lo, hi, wraps)
    edge = q[1] - q[0]
    per_item = np.array([q[0, 0] * q[1, 1] - q[0, 1] * q[1, 0], edge[0], edge[1]])
    beam, per_pair = _pairs(first, last, per_item, doubled)
    if len(beam) == 0:
        return
    u = np.take(fan.directions, beam, axis=1)  # np.take: 4x faster than fancy indexing along axis 1
    t = per_pair[0] / (u[0] * per_pair[2] - u[1] * per_pair[1])
    np.minimum.at(ranges, beam, np.where(t >= fan.range_min, t, np.inf))  # not behind the ray start, not nan


def circle_intervals(frame: ScanFrame, circles: np.ndarray) -> tuple[np.ndarray, np.ndarray, bool]:
    """Beam intervals (as _intervals) of the beams that may meet each circle (rows cx, cy, r).

    Conservative for a tilted scan (the circle is an ellipse in the beam plane: its radius is stretched
    by the largest); every beam when the origin is inside the (stretched) circle.
    """
    fan = frame.fan
    c = frame.to_plane @ (circles[:2] - frame.origin[:2, None])
    distance = np.hypot(c[0], c[1])
    radius = circles[2] * frame.stretch * (1.0 + 1e-9) + 1e-12
    half = np.arcsin(np.minimum(radius / np.maximum(distance, 1e-300), 1.0))
    start = np.mod(np.arctan2(c[1], c[0]) - half - fan.angle_min, 2.0 * math.pi) * fan.inverse_step
    inside = distance <= radius
    lo = np.where(inside, 0.0, start)
    hi = np.where(inside, fan.count - 1.0, start + 2.0 * half * fan.inverse_step)
    return _intervals(frame, lo, hi, True)


def cast_circles(frame: ScanFrame, circles: np.ndarray, ranges: np.ndarray) -> None:
    """Lower `ranges` to each beam's first hit on the upright circles (columns of rows cx, cy, r)."""
    if circles.shape[1] == 0:
        return
    rel = circles[:2] - frame.origin[:2, None]
    per_item = np.array([rel[0], rel[1], (rel * rel).sum(axis=0) - circles[2] ** 2])
    first, last, wrapped = circle_intervals(frame, circles)
    beam, per_pair = _pairs(first, last, per_item, wrapped)
    if len(beam) == 0:
        return
    h = np.take(frame.horizontal_directions(), beam, axis=1)  # beam directions' horizontal parts
    a = h[0] * h[0] + h[1] * h[1]
    b = h[0] * per_pair[0] + h[1] * per_pair[1]
    disc = b * b - a * per_pair[2]
    root = np.sqrt(np.maximum(disc, 0.0))
    near, far = (b - root) / a, (b + root) / a
    start = frame.fan.range_min
    t = np.where(near >= start, near, np.where(far >= start, far, np.inf))
    np.minimum.at(ranges, beam, np.where(disc >= 0, t, np.inf))


def circle_spans(frame: ScanFrame, circles: np.ndarray) -> list[tuple[int, int]]:
    """The beam intervals (first, last) that may meet one of the circles (rows cx, cy, r)."""
    if circles.shape[1] == 0:
        return []
    first, last, _ = circle_intervals(frame, circles)
    return [(lo, hi) for lo, hi in zip(first.astype(int).tolist(), last.astype(int).tolist()) if hi >= lo]


def near_items(table: np.ndarray, frame: ScanFrame, x_row: int, y_row: int, r_row: int) -> np.ndarray:
    """Mask of the items (columns) whose circle (x, y, r rows) comes within range_max of the origin."""
    distance = np.hypot(table[x_row] - frame.origin[0], table[y_row] - frame.origin[1])
    return distance <= table[r_row] + frame.fan.range_max
