"""The 3-D caster: MuJoCo's own ray casts (mj_multiRay), exact for any geometry and any tilt.

Only geoms of one group are seen (contacts' group: what a Gazebo ray sensor sees). The car must not see
itself, but mj_multiRay excludes just one body; so for the duration of a cast the car's geoms are moved
to another group (no physics reads geom_group) and put back at once.
"""

from __future__ import annotations

import mujoco
import numpy as np

from racecar_sim.physics.near_walls import WallBoxes
from racecar_sim.sensors.raycast.fan import ScanFrame


class MujocoRays:
    """Casts chosen beams of a scan in 3-D against the geoms in `group`, never hitting `hidden_geoms`, and against
    the map walls the model holds as data (`walls`, physics.near_walls), cast in a model of their own."""

    def __init__(
        self,
        model: mujoco.MjModel,
        data: mujoco.MjData,
        group: int,
        hidden_geoms: np.ndarray,
        walls: WallBoxes | None = None,
    ) -> None:
        self.model, self.data, self.group, self.walls = model, data, group, walls
        self.mask = np.zeros(mujoco.mjNGROUP, np.uint8)
        self.mask[group] = 1
        self.hidden = np.asarray(hidden_geoms, dtype=int)
        self.hidden_groups = model.geom_group[self.hidden].copy()
        self.elsewhere = (group + 1) % mujoco.mjNGROUP
        self._one = np.zeros(1, np.int32)
        self._walls_model: tuple[mujoco.MjModel, mujoco.MjData] | None = None

    def cast(self, frame: ScanFrame, beams: np.ndarray | slice = slice(None)) -> np.ndarray:
        """Distances (m) along the chosen beams to their first hit between range_min and range_max (else inf)."""
        fan = frame.fan
        return self.cast_rays(frame.origin, frame.directions_3d(beams), fan.range_min, fan.range_max)

    def cast_rays(self, origin: np.ndarray, directions: np.ndarray, range_min: float, range_max: float) -> np.ndarray:
        """Distances (m) from `origin` along world unit `directions` (n, 3) - any beam set: a fan, a cone, the rings of
        a 3-D lidar - to their first hit between range_min and range_max (else inf)."""
        directions = np.ascontiguousarray(directions, dtype=float)
        if len(directions) == 0:
            return np.empty(0)
        origin = np.asarray(origin, dtype=float)
        self.model.geom_group[self.hidden] = self.elsewhere
        try:
            dist = self._cast(self.model, self.data, origin, directions, range_min, range_max)
        finally:
            self.model.geom_group[self.hidden] = self.hidden_groups
        if self.walls is not None:
            if self._walls_model is None:  # built at the first 3-D scan of a map (tens of milliseconds)
                self._walls_model = self.walls.ray_model(self.group)
            walls = self._cast(*self._walls_model, origin, directions, range_min, range_max)
            np.minimum(dist, walls, out=dist)
        dist[dist > range_max] = np.inf
        return dist

    def _cast(
        self,
        model: mujoco.MjModel,
        data: mujoco.MjData,
        origin: np.ndarray,
        directions: np.ndarray,
        range_min: float,
        range_max: float,
    ) -> np.ndarray:
        n = len(directions)
        dist, geom = np.empty(n), np.empty(n, np.int32)
        mujoco.mj_multiRay(model, data, origin, directions.ravel(), self.mask, 1, -1, geom, dist, None, n, range_max)
        dist[geom < 0] = np.inf
        for i in np.flatnonzero(dist < range_min):  # something before the ray start: look past it
            start = origin + range_min * directions[i]
            d = mujoco.mj_ray(model, data, start, directions[i], self.mask, 1, -1, self._one)
            dist[i] = range_min + (np.inf if d < 0 else d)
        return dist
