"""The 2-D caster: beams against exact footprints of vertical prisms (walls compiled in kernels.py, upright
circles vectorised with numpy).

Each footprint is tested only by the beams inside its angular interval as seen from the sensor (polar
culling), so the work is proportional to the beam-footprint pairs that can hit, not beams x footprints.
Distances are 3-D distances along the (possibly tilted) beams, measured from the ray origin; a beam sees
the first surface at or beyond range_min, as a ray starting at range_min does (from inside a solid, that
is its far side, as MuJoCo's ray casts give it).

numpy's cost here is mostly per call, not per element, so the circle code keeps the number of array
operations per scan small rather than the arithmetic.
"""

from __future__ import annotations

import math
from collections.abc import Callable

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
    """Segments (a scene.py segment table) prepared for casting with the compiled kernel (kernels.py): per scan,
    a wall out of reach or facing away is dropped before any beam is tested against it."""

    def __init__(self, segments: np.ndarray, fan: Fan) -> None:
        self.fan, self.count = fan, segments.shape[1]
        self.table: np.ndarray | None = None
        self._kernel: Callable[..., None] | None = None  # kernels.cast_walls where there are walls
        if self.count:
            from racecar_sim.sensors.raycast import kernels  # numba: loaded by the first world with walls

            self.table, self._kernel = kernels.wall_table(segments, fan.range_min, fan.range_max), kernels.cast_walls

    def cast(self, frame: ScanFrame, ranges: np.ndarray) -> None:
        """Lower `ranges` to the distance of each beam's first hit on these walls (all covering frame's band)."""
        if self._kernel is None:  # no walls
            return
        fan = self.fan
        self._kernel(
            self.table,
            frame.origin,
            frame.to_plane,
            frame.rotation,
            frame.band[0],
            frame.band[1],
            False,
            fan.angle_min,
            fan.inverse_step,
            fan.count,
            fan.turn,
            fan.range_min,
            fan.directions,
            ranges,
        )


def circle_intervals(frame: ScanFrame, circles: np.ndarray) -> tuple[np.ndarray, np.ndarray, bool]:
    """Beam intervals (as _intervals) of the beams that may meet each circle (rows cx, cy, r).

    Conservative for a tilted scan (the circle is an ellipse in the beam plane: its radius is stretched
    by the largest); every beam when the origin is inside the (stretched) circle.
    """
    fan = frame.fan
    c = frame.to_plane @ (circles[:2] - frame.origin[:2, None])
    distance = np.hypot(c[0], c[1])
    radius = circles[2] * frame.stretch * (1.0 + 1e-9) + 1e-12
    # min(radius, distance): no overflow from a huge circle around the origin (inside it, `half` is not used)
    half = np.arcsin(np.minimum(np.minimum(radius, distance) / np.maximum(distance, 1e-300), 1.0))
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
    near: np.ndarray = distance <= table[r_row] + frame.fan.range_max
    return near
