"""A world's start line, where laps are counted and timed: a segment and the direction a car crosses it forward.

Where it comes from, first found:
  a link named `start_line` in the world (walker's checkered strip): its longest visual box, the line along its long
      side through its middle;
  a race track's centerline (a track CSV): across the track at its first point, from the right border to the left;
  a centerline without widths: across it at its first point, DEFAULT_HALF_WIDTH each side.
The forward direction is the centerline's at the line (or, without one, the spawn heading). `--start-line` / the
Simulator's `start_line=` give one instead.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from racecar_sim.core.transforms import quat_rotate
from racecar_sim.worlds.world import World, WorldGeom

DEFAULT_HALF_WIDTH = 1.5  # m each side of a centerline without track widths
LINK_NAME = "start_line"


@dataclass(frozen=True)
class StartLine:
    """The segment a..b (x, y in m) and the unit direction (x, y) a car crosses it in going forward."""

    a: tuple[float, float]
    b: tuple[float, float]
    forward: tuple[float, float]

    @classmethod
    def through(cls, ax: float, ay: float, bx: float, by: float, heading: float) -> StartLine:
        """The segment a..b, crossed forward along the side of it `heading` (rad) points to."""
        nx, ny = -(by - ay), bx - ax
        norm = math.hypot(nx, ny)
        if norm == 0:
            raise ValueError("a start line needs two different points")
        nx, ny = nx / norm, ny / norm
        if nx * math.cos(heading) + ny * math.sin(heading) < 0:
            nx, ny = -nx, -ny
        return cls((ax, ay), (bx, by), (nx, ny))

    def crossing(self, p0: tuple[float, float], p1: tuple[float, float]) -> float | None:
        """Where on the way p0 -> p1 (0..1) the car crosses the line forward, or None."""
        (ax, ay), (bx, by), (fx, fy) = self.a, self.b, self.forward
        d0 = (p0[0] - ax) * fx + (p0[1] - ay) * fy
        d1 = (p1[0] - ax) * fx + (p1[1] - ay) * fy
        if not (d0 < 0 <= d1):
            return None
        t = d0 / (d0 - d1)
        x, y = p0[0] + t * (p1[0] - p0[0]), p0[1] + t * (p1[1] - p0[1])
        along = (x - ax) * (bx - ax) + (y - ay) * (by - ay)
        return t if 0 <= along <= (bx - ax) ** 2 + (by - ay) ** 2 else None


def start_line_of(world: World) -> StartLine | None:
    """The world's start line, or None when it has neither a start-line link nor a centerline."""
    heading = world.spawn.yaw
    centerline = world.centerline
    if centerline is not None:
        d = centerline.points[1] - centerline.points[0]
        heading = math.atan2(float(d[1]), float(d[0]))
    for body in world.bodies:
        if body.name.split("::")[-1] != LINK_NAME:
            continue
        strips = [_footprint(g) for g in body.geoms if g.kind in ("box", "mesh")]
        if not strips:
            continue
        centre_local, half_local = max(strips, key=lambda s: float(np.abs(s[1]).max()))
        centre = np.asarray(body.pos, float) + quat_rotate(body.quat, centre_local)
        half = quat_rotate(body.quat, half_local)
        a, b = centre[:2] - half[:2], centre[:2] + half[:2]
        return StartLine.through(float(a[0]), float(a[1]), float(b[0]), float(b[1]), heading)
    if centerline is None:
        return None
    x, y = (float(v) for v in centerline.points[0])
    right, left = (DEFAULT_HALF_WIDTH, DEFAULT_HALF_WIDTH)
    if centerline.widths is not None:
        right, left = (float(v) for v in centerline.widths[0])
    cx, cy = math.cos(heading), math.sin(heading)  # left of the heading is (-cy, cx)
    return StartLine.through(x + cy * right, y - cx * right, x - cy * left, y + cx * left, heading)


def _footprint(geom: WorldGeom) -> tuple[np.ndarray, np.ndarray]:
    """A strip's middle and the half vector along its long side, in its body's frame (a textured box is a mesh)."""
    if geom.kind == "box":
        extents, middle = np.asarray(geom.size, float), np.zeros(3)
    else:
        assert geom.mesh is not None
        vertices = geom.mesh.vertices
        low, high = vertices.min(axis=0), vertices.max(axis=0)
        extents, middle = high - low, (high + low) / 2
    half = np.zeros(3)
    axis = 0 if extents[0] >= extents[1] else 1
    half[axis] = extents[axis] / 2
    return np.asarray(geom.pos, float) + quat_rotate(geom.quat, middle), quat_rotate(geom.quat, half)
