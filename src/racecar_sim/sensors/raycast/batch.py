"""One planar scan per world for many worlds at once: the compiled 2-D wall cast (kernels.cast_batch) in one
call, for a batch of copies of one scene that differ only in the sensor's pose.

The answer per beam is the one RayCaster.cast gives (the same kernel and formulas). Where a tilted scan's band
reaches past the top or bottom of a box (the car pitching, its beams reaching the floor box's top or passing over
a low wall), RayCaster recasts those beams with MuJoCo; here they stay in the kernel, exact for boxes: a hit on a
side counts only at the heights the box spans, and the beams may meet its top or bottom face. A world the path
cannot answer - a steep scan plane, a floor plane in the band, free bodies, circles, bounding cylinders, a partly
covering wall that is not a box's edge - is listed in `fallback`; the caller casts those with a RayCaster of its
own.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from racecar_sim.sensors.raycast.fan import MAX_TILT_COS, Fan
from racecar_sim.sensors.raycast.kernels import cast_batch, wall_table
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
        return cls(
            np.ascontiguousarray(origin, dtype=float), to_plane, np.stack([z - half, z + half], -1), steep, rotation
        )


class BatchWallCaster:
    """Casts a `Fan` against the static footprints of a scene from N poses at once (see the module doc).

    `has_moving`: the scene has free bodies the sensor may see (their poses differ per world): every scan
    then falls back. The cast is one compiled call (kernels.cast_batch) that releases the GIL.
    """

    def __init__(self, static: Footprints, fan: Fan, has_moving: bool) -> None:
        self.fan, self.has_moving = fan, has_moving
        seg = static.segments
        self.table = wall_table(seg, fan.range_min, fan.range_max)
        self.others = np.ascontiguousarray(np.concatenate([static.circles, static.bounds], axis=1))  # fall back near
        self.floors = np.ascontiguousarray(static.floors, dtype=float)
        self.always_3d = bool(static.not_prism_like)
        # the convex polygons (box footprints) the one-sided edges belong to, for their top and bottom faces
        one_sided = np.flatnonzero(seg[12] != 0)
        keys = np.stack([seg[9], seg[10], seg[11], seg[4], seg[5]])[:, one_sided]
        _, polygon = np.unique(keys, axis=1, return_inverse=True)
        polygon = polygon.ravel()
        self.polygon = np.full(seg.shape[1], -1, np.intp)
        self.polygon[one_sided] = polygon
        order = np.argsort(polygon, kind="stable")
        self.poly_edges = one_sided[order].astype(np.intp)
        self.poly_start = np.searchsorted(polygon[order], np.arange(int(polygon.max(initial=-1)) + 2)).astype(np.intp)

    def cast(self, frames: BatchFrames) -> tuple[np.ndarray, np.ndarray]:
        """Ranges (N, count) of every world's scan (inf where nothing is within range_max), and the indices
        of the worlds left to a RayCaster (their rows hold nothing meaningful)."""
        fan, n = self.fan, len(frames.origin)
        ranges = np.full((n, fan.count), np.inf)
        if self.always_3d or self.has_moving:
            return ranges, np.arange(n)
        fallback = np.zeros(n, bool)
        cast_batch(
            self.table,
            self.polygon,
            self.poly_start,
            self.poly_edges,
            self.floors,
            self.others,
            frames.origin,
            frames.to_plane,
            frames.rotation,
            frames.band,
            frames.steep,
            *fan.kernel_args,
            ranges,
            fallback,
        )
        return ranges, np.flatnonzero(fallback)
