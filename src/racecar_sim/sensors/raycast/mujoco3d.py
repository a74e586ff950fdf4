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
        directions = np.ascontiguousarray(frame.directions_3d(beams))
        if len(directions) == 0:
            return np.empty(0)
        self.model.geom_group[self.hidden] = self.elsewhere
        try:
            dist = self._cast(self.model, self.data, frame, directions)
        finally:
            self.model.geom_group[self.hidden] = self.hidden_groups
        if self.walls is not None:
            if self._walls_model is None:  # built at the first 3-D scan of a map (tens of milliseconds)
                self._walls_model = self.walls.ray_model(self.group)
            np.minimum(dist, self._cast(*self._walls_model, frame, directions), out=dist)
        dist[dist > frame.fan.range_max] = np.inf
        return dist

    def _cast(self, model: mujoco.MjModel, data: mujoco.MjData, frame: ScanFrame, directions: np.ndarray) -> np.ndarray:
        fan, n = frame.fan, len(directions)
        dist, geom = np.empty(n), np.empty(n, np.int32)
        mujoco.mj_multiRay(
            model, data, frame.origin, directions.ravel(), self.mask, 1, -1, geom, dist, None, n, fan.range_max
        )
        dist[geom < 0] = np.inf
        for i in np.flatnonzero(dist < fan.range_min):  # something before the ray start: look past it
            start = frame.origin + fan.range_min * directions[i]
            d = mujoco.mj_ray(model, data, start, directions[i], self.mask, 1, -1, self._one)
            dist[i] = fan.range_min + (np.inf if d < 0 else d)
        return dist
