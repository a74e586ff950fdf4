"""The world as a map_server map: a nav_msgs/OccupancyGrid of what the lidar sees, sliced at the scan plane.

Every static geom the lasers see (the collision group) and every wall box a map world holds out of MuJoCo
(physics.near_walls) is cut at the height of the scan plane with the lidar's own 2-D footprint code
(sensors/raycast/scene.py): an upright box is its rectangle, an upright cylinder its circle, an extruded mesh its
outline; any other shape (a sphere, a tilted box) its bounding circle, where that circle's z-range holds the plane.
A cell is occupied (100) when a footprint covers its centre or an outline passes through it (so a wall thinner
than a cell still shows), else free (0): the sim knows the whole world, so no cell is unknown. Free bodies (cones,
boxes that can be pushed) and the cars are not in the map, as a map_server map holds only what does not move.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass

import mujoco
import numpy as np
import numpy.typing as npt

from racecar_sim.physics import COLLISION_GROUP
from racecar_sim.physics.near_walls import WallBoxes
from racecar_sim.sensors.raycast.scene import Footprints, box_footprint, geom_footprint, is_static, seen_geoms

log = logging.getLogger("racecar_sim")

RESOLUTION = 0.05  # m per cell, as the F1TENTH maps (levine, Spielberg) are drawn
MARGIN = 1.0  # m of free cells around what the map holds
EMPTY_HALF = 10.0  # m each way from the cars when the world has no walls at the scan height
MAX_SIDE = 4096  # cells a side at most (16 Mcells, 16 MB a message); a larger world is drawn at a coarser resolution
OCCUPIED, FREE = 100, 0
_INSIDE = 1e-6  # m: how far inside a solid its edges are traced (far above float rounding, far below a cell)


@dataclass(frozen=True)
class Grid:
    """Cells (rows along y from the origin, columns along x), their size in m and the (x, y) of cell (0, 0)'s outer
    corner in the world."""

    cells: np.ndarray  # (rows, columns) int8
    resolution: float
    origin: tuple[float, float]

    def cell_of(self, x: npt.ArrayLike, y: npt.ArrayLike) -> tuple[np.ndarray, np.ndarray]:
        """(row, column) of the cells holding the points (x, y); outside the grid they are out of range."""
        col = np.floor((np.asarray(x) - self.origin[0]) / self.resolution).astype(int)
        row = np.floor((np.asarray(y) - self.origin[1]) / self.resolution).astype(int)
        return row, col


def slice_world(model: mujoco.MjModel, height: float) -> list[Footprints]:
    """Each static geom the lasers see, and each held-out wall box, as footprints cut at `height` (one per geom;
    the ones that do not reach that height are left out)."""
    scratch = mujoco.MjData(model)  # static poses do not depend on the state: the sim's data is not touched
    mujoco.mj_kinematics(model, scratch)
    parts: list[Footprints] = []
    for geom in seen_geoms(model, COLLISION_GROUP):
        if not is_static(model, int(geom)):
            continue
        pos, rotation = scratch.geom_xpos[geom].copy(), scratch.geom_xmat[geom].reshape(3, 3).copy()
        parts.append(_at_height(geom_footprint(model, int(geom), pos, rotation), height))
    walls = WallBoxes.of(model)
    if walls is not None:
        for pos, rotation, half in zip(walls.pos, walls.rotations(), walls.half):
            found = box_footprint(pos, rotation, half)
            if found is None:  # a tilted box: its bounding circle
                r = float(np.linalg.norm(half))
                found = Footprints(bounds=np.array([[pos[0]], [pos[1]], [r], [pos[2] - r], [pos[2] + r]]))
            parts.append(_at_height(found, height))
    return [p for p in parts if p.segments.shape[1] or p.circles.shape[1] or p.bounds.shape[1]]


def _at_height(part: Footprints, height: float) -> Footprints:
    """The part's segments and circles whose z-range holds `height` (bounds join the circles: a conservative cut)."""
    segments = part.segments[:, (part.segments[4] <= height) & (height <= part.segments[5])]
    circles = np.concatenate([part.circles, part.bounds], axis=1)
    circles = circles[:, (circles[3] <= height) & (height <= circles[4])]
    return Footprints(segments=segments, circles=circles)


def occupancy_grid(
    parts: list[Footprints], around: list[tuple[float, float]], resolution: float = RESOLUTION, label: str = "the world"
) -> Grid:
    """Rasterize the footprints into a grid covering them (and the points `around`, the cars) with MARGIN to spare;
    a grid wider than MAX_SIDE cells is drawn coarser (a warning names the resolution)."""
    lo, hi = _extent(parts, around)
    side = float(max(hi - lo))
    if side / resolution > MAX_SIDE:
        coarser = side / MAX_SIDE
        log.warning(
            "the F1TENTH /map of %s spans %.0f m: drawn at %.3g m per cell (at most %d cells a side)",
            label,
            side,
            coarser,
            MAX_SIDE,
        )
        resolution = coarser
    columns, rows = (max(1, math.ceil(float(v) / resolution)) for v in hi - lo)
    grid = Grid(np.full((rows, columns), FREE, np.int8), resolution, (float(lo[0]), float(lo[1])))
    for part in parts:
        _draw(grid, part)
    return grid


def _extent(parts: list[Footprints], around: list[tuple[float, float]]) -> tuple[np.ndarray, np.ndarray]:
    xs: list[np.ndarray] = [np.array([p[0] for p in around])]
    ys: list[np.ndarray] = [np.array([p[1] for p in around])]
    for part in parts:
        s, c = part.segments, part.circles
        xs += [s[0], s[2], c[0] - c[2], c[0] + c[2]]
        ys += [s[1], s[3], c[1] - c[2], c[1] + c[2]]
    x, y = np.concatenate(xs), np.concatenate(ys)
    if not parts:  # nothing at the scan height: a free square around the cars
        return np.array([x.min(), y.min()]) - EMPTY_HALF, np.array([x.max(), y.max()]) + EMPTY_HALF
    return np.array([x.min(), y.min()]) - MARGIN, np.array([x.max(), y.max()]) + MARGIN


def _draw(grid: Grid, part: Footprints) -> None:
    """Mark the part's outline cells, and the cells whose centres it covers."""
    segments = part.segments
    if segments.shape[1]:
        _mark_outline(grid, segments)
        if np.all(segments[12] == 1.0):  # one convex polygon wound counter-clockwise (a box): fill it
            _fill_convex(grid, segments)
    for cx, cy, r in part.circles[:3].T:
        _fill_circle(grid, cx, cy, r)


def _mark_outline(grid: Grid, segments: np.ndarray) -> None:
    """Every cell a segment passes through: its pieces between the grid lines it crosses, each marked at its middle
    (exact, where points sampled along it could miss a cell whose corner it clips). Each segment is taken a hair
    short of its ends, and the edge of a solid (one-sided, wound counter-clockwise) a hair inside it, so that a wall
    ending on a grid line marks no cell beyond it."""
    ox, oy = grid.origin
    res = grid.resolution
    for x0, y0, x1, y1, one_sided in segments[[0, 1, 2, 3, 12]].T:
        if one_sided:
            nx, ny = y0 - y1, x1 - x0  # the inward (left) normal
            shift = _INSIDE / max(math.hypot(nx, ny), 1e-300)
            x0, y0, x1, y1 = x0 + nx * shift, y0 + ny * shift, x1 + nx * shift, y1 + ny * shift
        cuts = [np.array([0.0, 1.0])]
        for a, b, o in ((x0, x1, ox), (y0, y1, oy)):
            if a != b:
                lines = o + res * np.arange(math.ceil((min(a, b) - o) / res), math.floor((max(a, b) - o) / res) + 1)
                cuts.append((lines - a) / (b - a))
        trim = min(0.25, _INSIDE / max(math.hypot(x1 - x0, y1 - y0), 1e-300))  # a hair short of each end
        t = np.unique(np.clip(np.concatenate(cuts), trim, 1.0 - trim))
        mid = 0.5 * (t[:-1] + t[1:]) if len(t) > 1 else t
        _mark(grid, x0 + mid * (x1 - x0), y0 + mid * (y1 - y0))


def _cell_centres(grid: Grid, xlo: float, ylo: float, xhi: float, yhi: float) -> tuple[np.ndarray, ...]:
    """Rows, columns and centre coordinates of the cells whose centres may lie in the box, clipped to the grid."""
    (r0, r1), (c0, c1) = (np.clip(v, 0, n - 1) for v, n in zip(grid.cell_of([xlo, xhi], [ylo, yhi]), grid.cells.shape))
    rows, cols = np.mgrid[r0 : r1 + 1, c0 : c1 + 1]
    ox, oy = grid.origin
    return rows, cols, ox + (cols + 0.5) * grid.resolution, oy + (rows + 0.5) * grid.resolution


def _fill_convex(grid: Grid, segments: np.ndarray) -> None:
    x0, y0, x1, y1 = segments[:4]
    rows, cols, cx, cy = _cell_centres(grid, x0.min(), y0.min(), x0.max(), y0.max())
    # left of (or on) every edge of a counter-clockwise polygon: inside
    cross = (x1 - x0)[:, None, None] * (cy - y0[:, None, None]) - (y1 - y0)[:, None, None] * (cx - x0[:, None, None])
    inside = np.all(cross >= 0.0, axis=0)
    grid.cells[rows[inside], cols[inside]] = OCCUPIED


def _fill_circle(grid: Grid, x: float, y: float, r: float) -> None:
    rows, cols, cx, cy = _cell_centres(grid, x - r, y - r, x + r, y + r)
    inside = (cx - x) ** 2 + (cy - y) ** 2 <= r * r
    grid.cells[rows[inside], cols[inside]] = OCCUPIED
    _mark(grid, np.array([x]), np.array([y]))  # a circle smaller than a cell still shows


def _mark(grid: Grid, x: np.ndarray, y: np.ndarray) -> None:
    rows, cols = grid.cell_of(x, y)
    keep = (rows >= 0) & (rows < grid.cells.shape[0]) & (cols >= 0) & (cols < grid.cells.shape[1])
    grid.cells[rows[keep], cols[keep]] = OCCUPIED
