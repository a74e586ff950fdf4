"""The 3-D caster: MuJoCo's own ray casts (mj_multiRay), exact for any geometry and any tilt.

Only geoms of one group are seen (contacts' group: what a Gazebo ray sensor sees). The car must not see
itself, but mj_multiRay excludes just one body; so for the duration of a cast the car's geoms are moved
to another group (no physics reads geom_group) and put back at once.
"""

from __future__ import annotations

import mujoco
import numpy as np

from racecar_sim.sensors.raycast.fan import ScanFrame


class MujocoRays:
    """Casts chosen beams of a scan in 3-D against the geoms in `group`, never hitting `hidden_geoms`."""

    def __init__(self, model: mujoco.MjModel, data: mujoco.MjData, group: int, hidden_geoms: np.ndarray) -> None:
        self.model, self.data = model, data
        self.mask = np.zeros(mujoco.mjNGROUP, np.uint8)
        self.mask[group] = 1
        self.hidden = np.asarray(hidden_geoms, dtype=int)
        self.hidden_groups = model.geom_group[self.hidden].copy()
        self.elsewhere = (group + 1) % mujoco.mjNGROUP
        self._one = np.zeros(1, np.int32)

    def cast(self, frame: ScanFrame, beams: np.ndarray | slice = slice(None)) -> np.ndarray:
        """Distances (m) along the chosen beams to their first hit between range_min and range_max (else inf)."""
        fan = frame.fan
        directions = np.ascontiguousarray(frame.directions_3d(beams))
        n = len(directions)
        dist, geom = np.empty(n), np.empty(n, np.int32)
        if n == 0:
            return dist
        self.model.geom_group[self.hidden] = self.elsewhere
        try:
            mujoco.mj_multiRay(self.model, self.data, frame.origin, directions.ravel(), self.mask, 1, -1, geom, dist,
                               None, n, fan.range_max)
            dist[geom < 0] = np.inf
            for i in np.flatnonzero(dist < fan.range_min):  # something before the ray start: look past it
                dist[i] = fan.range_min + self._ray(frame.origin + fan.range_min * directions[i], directions[i])
        finally:
            self.model.geom_group[self.hidden] = self.hidden_groups
        dist[dist > fan.range_max] = np.inf
        return dist

    def _ray(self, start: np.ndarray, direction: np.ndarray) -> float:
        d = mujoco.mj_ray(self.model, self.data, start, direction, self.mask, 1, -1, self._one)
        return np.inf if d < 0 else d
