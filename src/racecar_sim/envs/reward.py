"""The progress reward: metres gained along a world's centerline, or along the car's heading where none is known.

Where the centerline comes from, first match wins:
  1. the env's `centerline=` argument: a track CSV (x, y, w_right, w_left: a closed loop) or a path/waypoint CSV
     (x, y [, speed], read as pure-pursuit reads it: a loop when its ends meet);
  2. the world's own (World.centerline, set by its loader): a track CSV's, or a built-in world's (walker's);
  3. none: progress is the distance driven along the car's heading (dot(displacement, heading)).
"""

from __future__ import annotations

import math
from pathlib import Path

from racecar_sim.core.errors import WorldError
from racecar_sim.worlds import World
from racecar_sim.worlds.world import SEARCH_WINDOW, Centerline

__all__ = ["SEARCH_WINDOW", "Centerline", "Progress", "load_centerline", "world_centerline"]


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
    return world.centerline


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
