"""The progress reward: metres gained along a world's centerline, or along the car's heading where none is known.

Where the centerline comes from, first match wins:
  1. the env's `centerline=` argument: a track CSV (x, y, w_right, w_left: a closed loop) or a path/waypoint CSV
     (x, y [, speed], read as pure-pursuit reads it: a loop when its ends meet);
  2. a world loaded from a track CSV: its own centerline;
  3. a built-in world listed in data/centerlines.yaml (walker);
  4. none: progress is the distance driven along the car's heading (dot(displacement, heading)).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import yaml

from racecar_sim.core.errors import ConfigError, WorldError
from racecar_sim.worlds import World

DATA = Path(__file__).parent / "data"
BUILTIN_CENTERLINES: dict[str, str] = yaml.safe_load((DATA / "centerlines.yaml").read_text())
SEARCH_WINDOW = 5.0  # m of arc length either side of the last projection searched for the next one


class Centerline:
    """A polyline (N, 2), closed (a loop) or open, with arc-length projection of points onto it."""

    def __init__(self, points: np.ndarray, closed: bool, source: str = "") -> None:
        points = np.asarray(points, np.float64)
        if closed and len(points) > 1 and np.array_equal(points[0], points[-1]):
            points = points[:-1]
        if len(points) < 2:
            raise ConfigError(f"{source or 'centerline'}: needs at least 2 points, got {len(points)}")
        self.points, self.closed, self.source = points, closed, source
        ends = np.roll(points, -1, axis=0) if closed else points[1:]
        self._start = points[:len(ends)]
        self._delta = ends - self._start
        self._seg_len = np.hypot(self._delta[:, 0], self._delta[:, 1])
        if np.any(self._seg_len == 0):
            raise ConfigError(f"{source or 'centerline'}: two consecutive points are equal")
        self._s0 = np.concatenate([[0.0], np.cumsum(self._seg_len)[:-1]])
        self.length = float(self._seg_len.sum())

    def project(self, x: float, y: float, near: float | None = None) -> float:
        """Arc length s of the point of the line nearest to (x, y); with `near`, only segments within
        SEARCH_WINDOW of arc length `near` count (the line may pass close to itself elsewhere)."""
        px, py = x - self._start[:, 0], y - self._start[:, 1]
        t = np.clip((px * self._delta[:, 0] + py * self._delta[:, 1]) / self._seg_len**2, 0.0, 1.0)
        dist = np.hypot(px - t * self._delta[:, 0], py - t * self._delta[:, 1])
        s = self._s0 + t * self._seg_len
        if near is not None:
            far = np.abs(self.wrap(s - near)) > SEARCH_WINDOW
            if not np.all(far):
                dist = np.where(far, np.inf, dist)
        return float(s[int(np.argmin(dist))])

    def wrap(self, ds: np.ndarray | float) -> np.ndarray | float:
        """An arc-length difference taken the short way round a loop (unchanged on an open line)."""
        if not self.closed:
            return ds
        half = self.length / 2
        return (np.asarray(ds) + half) % self.length - half


def load_centerline(path: str | Path) -> Centerline:
    """A centerline from a CSV: a track (x, y, w_right, w_left; always a loop) or a path (x, y [, speed])."""
    from racecar_sim.drivers.waypoints import load_waypoints
    from racecar_sim.worlds.centerline import read_centerline

    path = Path(path)
    try:
        points = read_centerline(path)[0]
        return Centerline(points, True, str(path))
    except WorldError:  # not a track: read it as a waypoint path (which gives its own one-line errors)
        waypoints = load_waypoints(path)
        return Centerline(waypoints.points, waypoints.closed, str(path))


def world_centerline(world: World, centerline: str | Path | None = None) -> Centerline | None:
    """The centerline progress is measured along in `world` (see the module doc), None for distance driven."""
    if centerline is not None:
        return load_centerline(centerline)
    source = getattr(world, "source", "") or ""
    if str(source).lower().endswith(".csv"):
        return load_centerline(source)
    if world.name in BUILTIN_CENTERLINES:
        return load_centerline(DATA / BUILTIN_CENTERLINES[world.name])
    return None


class Progress:
    """Progress of one car per control step: arc length gained along the centerline, or the distance driven
    along its heading when there is no centerline. reset() at the spawn pose; step() returns metres."""

    def __init__(self, centerline: Centerline | None) -> None:
        self.centerline = centerline
        self._s = 0.0
        self._xy = (0.0, 0.0)

    def reset(self, x: float, y: float) -> None:
        """Start measuring at (x, y)."""
        self._xy = (x, y)
        if self.centerline is not None:
            self._s = self.centerline.project(x, y)

    def step(self, x: float, y: float, yaw: float) -> float:
        """Metres gained since the last call (negative going backwards)."""
        if self.centerline is None:
            gained = (x - self._xy[0]) * math.cos(yaw) + (y - self._xy[1]) * math.sin(yaw)
        else:
            s = self.centerline.project(x, y, near=self._s)
            gained = float(self.centerline.wrap(s - self._s))
            self._s = s
        self._xy = (x, y)
        return gained
