"""One planar scan per world for many worlds at once: the 2-D wall cast of planar.py as array code over
(world, beam, wall) triples, for a batch of copies of one scene that differ only in the sensor's pose.

The answer per beam is the one RayCaster.cast gives (the same formulas; the operations are batched, so a
range may differ in its last bits). Where a tilted scan's band reaches past the top or bottom of a box (the car
pitching, its beams reaching the floor box's top or passing over a low wall), RayCaster recasts those beams
with MuJoCo; here they stay array code, exact for boxes: a hit on a side counts only at the heights the box
spans, and the beams may meet its top or bottom face. A world the path cannot answer - a steep scan plane, a
floor plane in the band, free bodies, circles, bounding cylinders, a partly covering wall that is not a box's
edge - is listed in `fallback`; the caller casts those with a RayCaster of its own.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from racecar_sim.sensors.raycast.fan import INDEX_SLACK, MAX_TILT_COS, Fan
from racecar_sim.sensors.raycast.scene import Footprints


@dataclass(frozen=True)
class BatchFrames:
    """Where N scans are cast from: ray origins (N, 3), the plane maps (N, 2, 2), height bands (N, 2) and
    which scans are too steep for 2-D (ScanFrame's quantities, one row per world)."""

    origin: np.ndarray
    to_plane: np.ndarray
    band: np.ndarray
    steep: np.ndarray
    rotation: np.ndarray  # (N, 3, 3) world from sensor

    @classmethod
    def from_poses(cls, origin: np.ndarray, rotation: np.ndarray, fan: Fan) -> BatchFrames:
        """Frames of ray origins (N, 3) with sensor axes `rotation` (N, 3, 3, world from sensor)."""
        e1x, e2x = rotation[:, 0, 0], rotation[:, 0, 1]
        e1y, e2y = rotation[:, 1, 0], rotation[:, 1, 1]
        e1z, e2z = rotation[:, 2, 0], rotation[:, 2, 1]
        det = e1x * e2y - e2x * e1y
        half = fan.range_max * np.hypot(e1z, e2z) * (1.0 + 1e-12) + 1e-12
        z = origin[:, 2]
        steep = det < MAX_TILT_COS
        safe = np.where(steep, 1.0, det)
        to_plane = np.stack([np.stack([e2y / safe, -e2x / safe], -1), np.stack([-e1y / safe, e1x / safe], -1)], 1)
        return cls(np.ascontiguousarray(origin, dtype=float), to_plane, np.stack([z - half, z + half], -1), steep,
                   rotation)


class BatchWallCaster:
    """Casts a `Fan` against the static footprints of a scene from N poses at once (see the module doc).

    `has_moving`: the scene has free bodies the sensor may see (their poses differ per world): every scan
    then falls back.
    """

    def __init__(self, static: Footprints, fan: Fan, has_moving: bool) -> None:
        self.fan, self.has_moving = fan, has_moving
        seg = static.segments
        x0, y0, x1, y1 = seg[:4]
        self.ends = seg[:4]
        self.zlo, self.zhi = seg[4], seg[5]
        self.mid, self.reach = seg[6:8], seg[8] + fan.range_max
        self.circle, self.circle_reach = seg[9:11], seg[11] + fan.range_min
        # squared, and a little larger: these tests only cull, and keeping a wall too many changes no range
        self.reach2 = (self.reach * (1.0 + 1e-9)) ** 2
        self.circle_reach2 = (self.circle_reach * (1.0 + 1e-9)) ** 2
        self.cross = x0 * y1 - y0 * x1
        self.edge = np.array([x1 - x0, y1 - y0])
        self.two_sided = seg[12] == 0
        self.others = np.concatenate([static.circles, static.bounds], axis=1)  # anything else: fall back near it
        self.floors = static.floors
        self.always_3d = bool(static.not_prism_like)
        self._tiled = np.zeros((2, 0))
        # the convex polygons (box footprints) the one-sided edges belong to, for their top and bottom faces
        one_sided = np.flatnonzero(~self.two_sided)
        keys = np.stack([seg[9], seg[10], seg[11], seg[4], seg[5]])[:, one_sided]
        _, polygon = np.unique(keys, axis=1, return_inverse=True)
        self.polygon = np.full(seg.shape[1], -1)
        self.polygon[one_sided] = polygon.ravel()
        self.polygons = [one_sided[polygon.ravel() == k] for k in range(int(polygon.max(initial=-1)) + 1)]

    def cast(self, frames: BatchFrames) -> tuple[np.ndarray, np.ndarray]:
        """Ranges (N, count) of every world's scan (inf where nothing is within range_max), and the indices
        of the worlds left to a RayCaster (their rows hold nothing meaningful)."""
        fan, n = self.fan, len(frames.origin)
        ranges = np.full((n, fan.count), np.inf)
        fallback = self._fallback(frames)
        x, y = frames.origin[:, 0, None], frames.origin[:, 1, None]
        lo, hi = frames.band[:, 0, None], frames.band[:, 1, None]
        dx, dy = self.mid[0] - x, self.mid[1] - y
        near = dx * dx + dy * dy <= self.reach2  # (N, walls)
        covers = (self.zlo <= lo) & (self.zhi >= hi)
        partly = ~covers & (self.zlo < hi) & (self.zhi > lo)
        # walls covering part of the band: exact in 3-D when they are edges of boxes (a hit on a side counts at
        # the heights the box spans; the beams may also meet its top or bottom face); else fall back
        partly_near = near & partly
        tilted = partly_near.any(axis=1) & ~fallback
        fallback |= tilted & (partly_near & self.two_sided).any(axis=1)
        tilted &= ~fallback
        cx, cy = self.circle[0] - x, self.circle[1] - y
        facing = ((self.cross - x * self.edge[1] + y * self.edge[0] < 0)
                  | (cx * cx + cy * cy <= self.circle_reach2) | self.two_sided)
        world, wall = np.nonzero(near & (covers | (partly & tilted[:, None])) & facing & ~fallback[:, None])
        with np.errstate(divide="ignore", invalid="ignore"):  # beams exactly parallel to a wall
            if len(world):
                self._cast_segments(frames, world, wall, ranges, partly[world, wall] & tilted[world])
            for w in np.flatnonzero(tilted).tolist():
                self._cast_faces(frames, w, np.unique(self.polygon[partly_near[w]]), ranges)
        ranges[ranges > fan.range_max] = np.inf
        return ranges, np.flatnonzero(fallback)

    def _fallback(self, frames: BatchFrames) -> np.ndarray:
        n = len(frames.origin)
        if self.always_3d or self.has_moving:
            return np.ones(n, bool)
        lo, hi = frames.band[:, 0, None], frames.band[:, 1, None]
        fallback = frames.steep | ((self.floors >= lo) & (self.floors <= hi)).any(axis=1)
        if self.others.shape[1]:
            o = self.others
            reach = np.hypot(o[0] - frames.origin[:, 0, None], o[1] - frames.origin[:, 1, None]) <= o[2] + self.fan.range_max
            fallback |= (reach & (o[3] < hi) & (o[4] > lo)).any(axis=1)
        return fallback

    def _cast_segments(self, frames: BatchFrames, world: np.ndarray, wall: np.ndarray, ranges: np.ndarray,
                       spans: np.ndarray) -> None:
        """planar.cast_segments for (world, wall) pairs: lower each world's ranges to its beams' first hits.
        Where `spans`, a hit counts only at the heights the wall spans."""
        zlo, zhi = self.zlo[wall], self.zhi[wall]
        fan = self.fan
        plane = frames.to_plane[world]  # (P, 2, 2)
        rel = self.ends[:, wall].reshape(2, 2, -1) - frames.origin[world, :2].T[None]  # [end][x|y][pair]
        q = plane[:, :, 0].T * rel[:, 0, None] + plane[:, :, 1].T * rel[:, 1, None]  # [end][x|y][pair]
        pos = (np.arctan2(q[:, 1], q[:, 0]) - fan.angle_min) * fan.inverse_step
        lo, hi = np.minimum(pos[0], pos[1]), np.maximum(pos[0], pos[1])
        behind = hi - lo > 0.5 * fan.turn
        lo, hi = np.where(behind, hi, lo), np.where(behind, lo + fan.turn, hi)
        first = np.maximum(np.ceil(lo - INDEX_SLACK), 0.0)
        last = np.minimum(np.floor(hi + INDEX_SLACK), fan.count - 1)
        edge = q[1] - q[0]
        per_item = np.array([q[0, 0] * q[1, 1] - q[0, 1] * q[1, 0], edge[0], edge[1]])
        if behind.any() and (hi.max() + INDEX_SLACK >= fan.turn):  # parts running past a full turn
            wrapped = np.minimum(np.floor(hi - fan.turn + INDEX_SLACK), fan.count - 1)
            first, last = np.concatenate([first, np.zeros_like(first)]), np.concatenate([last, wrapped])
            per_item = np.concatenate([per_item, per_item], axis=1)
            world, spans = np.concatenate([world, world]), np.concatenate([spans, spans])
            zlo, zhi = np.concatenate([zlo, zlo]), np.concatenate([zhi, zhi])
        counts = np.maximum(last - first + 1.0, 0.0).astype(np.intp)
        offsets = np.cumsum(counts)
        if len(offsets) == 0 or offsets[-1] == 0:
            return
        # flat index world * count + beam of every (beam, wall) pair, and the beam directions, in one repeat each
        flat = np.arange(offsets[-1]) + np.repeat(world * fan.count + first.astype(np.intp) - offsets + counts, counts)
        per_pair = np.repeat(per_item, counts, axis=1)
        u = np.take(self._directions(len(ranges)), flat, axis=1)
        t = per_pair[0] / (u[0] * per_pair[2] - u[1] * per_pair[1])
        if spans.any():
            pair = np.flatnonzero(np.repeat(spans, counts))
            cell = flat[pair]
            rise = self._rise(frames).reshape(-1)[cell]  # dz/dt of the beam
            z = frames.origin[cell // fan.count, 2] + t[pair] * rise
            t[pair[(z < np.repeat(zlo, counts)[pair]) | (z > np.repeat(zhi, counts)[pair])]] = np.inf
        np.minimum.at(ranges.reshape(-1), flat, np.where(t >= fan.range_min, t, np.inf))

    def _rise(self, frames: BatchFrames) -> np.ndarray:
        """The world z component (N, count) of every world's unit beam directions."""
        u = self.fan.directions
        return frames.rotation[:, 2, 0, None] * u[0] + frames.rotation[:, 2, 1, None] * u[1]

    def _cast_faces(self, frames: BatchFrames, w: int, polygons: np.ndarray, ranges: np.ndarray) -> None:
        """Lower world w's ranges to the hits on the top and bottom faces of the chosen polygons (boxes)."""
        fan, origin, rotation = self.fan, frames.origin[w], frames.rotation[w]
        u = fan.directions
        hx, hy = rotation[0, :2] @ u, rotation[1, :2] @ u
        rise = rotation[2, :2] @ u
        lo, hi = frames.band[w]
        for k in polygons.tolist():
            edges = self.polygons[k]
            bottom, top = self.zlo[edges[0]], self.zhi[edges[0]]
            # only a face inside the band and facing the origin can be the first hit (else a side is nearer)
            faces = [z for z, seen in ((bottom, origin[2] <= bottom <= hi), (top, lo <= top <= origin[2])) if seen]
            for height in faces:
                t = (height - origin[2]) / rise
                px, py = origin[0] + t * hx, origin[1] + t * hy
                inside = t >= fan.range_min
                for e in edges.tolist():  # counter-clockwise: inside is left of every edge
                    ex, ey = self.edge[0, e], self.edge[1, e]
                    inside &= ex * (py - self.ends[1, e]) - ey * (px - self.ends[0, e]) >= 0
                np.minimum(ranges[w], np.where(inside, t, np.inf), out=ranges[w])

    def _directions(self, n: int) -> np.ndarray:
        """The fan's directions (2, count) repeated for n worlds: (2, n * count)."""
        if self._tiled.shape[1] < n * self.fan.count:
            self._tiled = np.tile(self.fan.directions, n)
        return self._tiled

