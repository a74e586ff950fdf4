"""Race tracks as worlds: a closed centerline CSV (x, y, w_right, w_left per row) walled along both borders.

The format of the F1TENTH racetrack database: metres, comma separated, `#` header lines optional. The last
point joins the first; a last row repeating the first point is dropped. Borders are the centerline moved
w_left to the left and w_right to the right (averaged normals), simplified to within BORDER_TOLERANCE.
"""

from __future__ import annotations

import math
import warnings
from pathlib import Path

import numpy as np

from racecar_sim.core.errors import WorldError
from racecar_sim.worlds.walls import border_walls, offset_polyline, simplify
from racecar_sim.worlds.world import Spawn, World, WorldBody, WorldGeom

COLUMNS = ("x", "y", "w_right", "w_left")
BORDER_TOLERANCE = 0.01  # m, a simplified border stays this close to the offset centerline
WALL_THICKNESS = 0.1  # m


def load_track(path: str | Path, wall_height: float) -> World:
    """The track at `path` on Gazebo's ground plane, walls outside both borders, the car on the first point."""
    from racecar_sim.worlds.catalog import load_world  # catalog imports this module lazily

    path = Path(path)
    points, w_right, w_left, line_numbers = read_centerline(path)
    geoms: list[WorldGeom] = []
    borders = []
    for side, widths in (("left", w_left), ("right", w_right)):
        try:
            border = offset_polyline(points, widths, side, closed=True)
            _warn_if_folded(path, points, border, side, line_numbers)
            border = simplify(border, BORDER_TOLERANCE, closed=True)
            borders.append(border)
            geoms += border_walls(border, True, side, WALL_THICKNESS, wall_height, name=f"{side}_wall")
        except ValueError as exc:  # a centerline that doubles back, or a border that collapses to a point
            raise WorldError(f"{path}: {exc}") from None
    world = load_world("empty")
    world.name, world.source = path.stem, str(path)
    world.bodies.append(WorldBody("track", np.zeros(3), np.array([1.0, 0.0, 0.0, 0.0]), static=True, geoms=geoms))
    world.cover_ground(np.concatenate(borders))
    (x0, y0), (x1, y1) = points[:2]
    world.spawn = Spawn(float(x0), float(y0), Spawn().z, math.atan2(y1 - y0, x1 - x0))
    return world


def _warn_if_folded(path: Path, points: np.ndarray, border: np.ndarray, side: str, line_numbers: list[int]) -> None:
    """A warning where a border runs backwards: the width exceeds the turn's radius and its walls cross the track."""
    forward = np.einsum("ij,ij->i", np.roll(points, -1, axis=0) - points, np.roll(border, -1, axis=0) - border)
    if np.any(forward <= 0):
        line = line_numbers[int(np.flatnonzero(forward <= 0)[0])]
        warnings.warn(f"{path}: line {line}: the {side} border folds over itself (w_{side} exceeds the turn "
                      "radius), so its walls cross the track", stacklevel=2)


def read_centerline(path: Path) -> tuple[np.ndarray, np.ndarray, np.ndarray, list[int]]:
    """Points (N, 2), w_right (N,), w_left (N,) and their CSV line numbers, checked; errors name file and line."""
    try:
        lines = path.read_text(encoding="utf-8-sig").splitlines()
    except (OSError, UnicodeDecodeError) as exc:
        raise WorldError(f"{path}: cannot read: {exc}") from None
    rows, numbers = [], []
    for n, line in enumerate(lines, start=1):
        if not line.strip() or line.lstrip().startswith("#"):
            continue
        rows.append(n)
        numbers.append(_parse_row(path, n, line))
    table = np.array(numbers, dtype=float).reshape(-1, 4)
    points, w_right, w_left = table[:, :2], table[:, 2], table[:, 3]
    if len(points) > 1 and np.array_equal(points[0], points[-1]):
        points, w_right, w_left, rows = points[:-1], w_right[:-1], w_left[:-1], rows[:-1]
    if len(points) < 3:
        raise WorldError(f"{path}: a closed track needs at least 3 centerline points, got {len(points)}")
    step = np.hypot(*(np.roll(points, -1, axis=0) - points).T)
    if np.any(step == 0):
        i = int(np.flatnonzero(step == 0)[0])
        raise WorldError(f"{path}: line {rows[(i + 1) % len(rows)]}: repeats the point of line {rows[i]}")
    return points, w_right, w_left, rows


def _parse_row(path: Path, n: int, line: str) -> list[float]:
    """x, y, w_right, w_left of one data line: four finite numbers, positive widths."""
    fields = [f.strip() for f in line.split(",")]
    if len(fields) != len(COLUMNS):
        raise WorldError(f"{path}: line {n}: expected {len(COLUMNS)} comma-separated columns "
                         f"({', '.join(COLUMNS)}), got {len(fields)}")
    values = []
    for name, field in zip(COLUMNS, fields):
        try:
            value = float(field)
        except ValueError:
            raise WorldError(f"{path}: line {n}: {name}: not a number: {field!r}") from None
        if not math.isfinite(value):
            raise WorldError(f"{path}: line {n}: {name}: must be finite, got {field}")
        if name.startswith("w_") and value <= 0:
            raise WorldError(f"{path}: line {n}: {name}: track width must be positive, got {field}")
        values.append(value)
    return values
