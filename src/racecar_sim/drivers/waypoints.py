"""The paths pure-pursuit follows: a race-track centerline, an F1TENTH raceline or a waypoint CSV."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from racecar_sim.core.errors import ConfigError
from racecar_sim.worlds.centerline import SPEED_NAMES, X_NAMES, Y_NAMES, read_csv_table


@dataclass(frozen=True)
class Waypoints:
    """Points (N, 2) in the world frame, optional target speeds (N,), and whether the last joins the first."""

    points: np.ndarray
    speeds: np.ndarray | None
    closed: bool
    source: str = ""


def load_waypoints(path: str | Path) -> Waypoints:
    """Read a path CSV: `x, y` (waypoints), `x, y, speed`, `x, y, w_right, w_left` (an F1TENTH centerline), or any
    table whose header names the columns, as the F1TENTH racelines' `# s_m; x_m; y_m; psi_rad; kappa_radpm;
    vx_mps; ax_mps2` (x_m, y_m, and vx_mps as the speed).

    Comma or semicolon separated; the header is a plain first row or the last `#` line before the data
    (read_csv_table, shared with the track loader). Without a header naming x and y, the first two columns are
    x, y and a third of exactly three is the speed. A path whose ends lie within two mean spacings of each
    other is a loop.
    """
    table = read_csv_table(path, ConfigError)
    path = table.path
    x, y = table.find(X_NAMES), table.find(Y_NAMES)
    if x is not None and y is not None:
        speed = table.find(SPEED_NAMES)
    elif table.rows and table.width < 2:
        raise table.fail(table.lines[0], f"need at least 2 columns (x, y), got {table.width}")
    else:
        x, y, speed = 0, 1, 2 if table.width == 3 else None
    columns = [(x, "x"), (y, "y")] + ([(speed, "speed")] if speed is not None else [])
    values = table.numbers(columns)
    if len(values) < 2:
        raise ConfigError(f"{path}: a path needs at least 2 points, got {len(values)}")
    points = values[:, :2]
    speeds = values[:, 2] if speed is not None else None
    if speeds is not None and np.any(speeds <= 0):
        line = table.lines[int(np.flatnonzero(speeds <= 0)[0])]
        raise table.fail(line, f"speed: must be positive, got {speeds[speeds <= 0][0]:g}")
    steps = np.hypot(*np.diff(points, axis=0).T)
    if np.any(steps == 0):
        keep = np.concatenate([[True], steps > 0])
        points, speeds = points[keep], None if speeds is None else speeds[keep]
        steps = steps[steps > 0]
        if len(points) < 2:
            raise ConfigError(f"{path}: a path needs at least 2 distinct points, got {len(points)}")
    gap = float(np.hypot(*(points[-1] - points[0])))
    closed = len(points) > 2 and gap <= 2 * float(np.mean(steps))
    if closed and gap == 0:
        points, speeds = points[:-1], None if speeds is None else speeds[:-1]
    return Waypoints(points, speeds, closed, str(path))
