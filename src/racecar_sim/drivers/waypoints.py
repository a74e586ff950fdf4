"""The paths pure-pursuit follows: a race-track centerline CSV or a waypoint CSV."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from racecar_sim.core.errors import ConfigError


@dataclass(frozen=True)
class Waypoints:
    """Points (N, 2) in the world frame, optional target speeds (N,), and whether the last joins the first."""

    points: np.ndarray
    speeds: np.ndarray | None
    closed: bool
    source: str = ""


def load_waypoints(path: str | Path) -> Waypoints:
    """Read `x, y` (waypoints), `x, y, speed`, or `x, y, w_right, w_left` (an F1TENTH centerline) rows.

    `#` lines are comments; a path whose ends lie within two mean spacings of each other is a loop.
    """
    path = Path(path)
    rows: list[list[float]] = []
    try:
        lines = path.read_text().splitlines()
    except OSError as exc:
        raise ConfigError(f"{path}: cannot read the path: {exc.strerror or exc}") from None
    for number, line in enumerate(lines, 1):
        text = line.split("#", 1)[0].strip()
        if not text:
            continue
        try:
            values = [float(v) for v in text.replace(";", ",").split(",")]
        except ValueError:
            raise ConfigError(f"{path}: line {number}: not a row of numbers: {line.strip()!r}") from None
        if len(values) < 2 or not np.all(np.isfinite(values)):
            raise ConfigError(f"{path}: line {number}: need finite x, y (got {line.strip()!r})")
        if rows and len(values) != len(rows[0]):
            raise ConfigError(f"{path}: line {number}: {len(values)} columns, the first row has {len(rows[0])}")
        rows.append(values)
    if len(rows) < 2:
        raise ConfigError(f"{path}: a path needs at least 2 points, got {len(rows)}")
    table = np.array(rows)
    points = table[:, :2]
    speeds = table[:, 2] if table.shape[1] == 3 else None
    if speeds is not None and np.any(speeds <= 0):
        raise ConfigError(f"{path}: the speed column must be positive")
    steps = np.hypot(*np.diff(points, axis=0).T)
    if np.any(steps == 0):
        keep = np.concatenate([[True], steps > 0])
        points, speeds = points[keep], None if speeds is None else speeds[keep]
        steps = steps[steps > 0]
    gap = float(np.hypot(*(points[-1] - points[0])))
    closed = len(points) > 2 and gap <= 2 * float(np.mean(steps))
    if closed and gap == 0:
        points, speeds = points[:-1], None if speeds is None else speeds[:-1]
    return Waypoints(points, speeds, closed, str(path))
