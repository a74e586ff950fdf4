"""The progress reward and the crash check of DriveEnv, over a batch of worlds (reward.py and crash.py vectorised)."""

from __future__ import annotations

import mujoco
import numpy as np

from racecar_sim.envs.crash import SUPPORT_NORMAL_Z
from racecar_sim.envs.reward import SEARCH_WINDOW, Centerline


class BatchProgress:
    """reward.Progress for N cars: arc length gained along the centerline, or distance along the heading."""

    def __init__(self, centerline: Centerline | None, n: int) -> None:
        self.centerline = centerline
        self.s, self.xy = np.zeros(n), np.zeros((n, 2))

    @staticmethod
    def _project(c: Centerline, xy: np.ndarray, near: np.ndarray | None) -> np.ndarray:
        px, py = xy[:, 0, None] - c._start[:, 0], xy[:, 1, None] - c._start[:, 1]
        t = np.clip((px * c._delta[:, 0] + py * c._delta[:, 1]) / c._seg_len**2, 0.0, 1.0)
        dist = np.hypot(px - t * c._delta[:, 0], py - t * c._delta[:, 1])
        s = c._s0 + t * c._seg_len
        if near is not None:
            far = np.abs(c.wrap(s - near[:, None])) > SEARCH_WINDOW
            dist = np.where(far & ~far.all(axis=1, keepdims=True), np.inf, dist)
        return s[np.arange(len(xy)), np.argmin(dist, axis=1)]

    def reset(self, worlds: np.ndarray, xy: np.ndarray) -> None:
        """Start measuring the chosen worlds at xy (len(worlds), 2)."""
        self.xy[worlds] = xy
        if self.centerline is not None:
            self.s[worlds] = self._project(self.centerline, xy, None)

    def step(self, xy: np.ndarray, yaw: np.ndarray) -> np.ndarray:
        """Metres gained by every world since the last call."""
        gained: np.ndarray
        if self.centerline is None:
            d = xy - self.xy
            gained = d[:, 0] * np.cos(yaw) + d[:, 1] * np.sin(yaw)
        else:
            s = self._project(self.centerline, xy, self.s)
            gained = np.asarray(self.centerline.wrap(s - self.s), float)
            self.s = s
        self.xy = xy.copy()
        return gained


class CrashTable:
    """crash.CrashMonitor's rule for one car as a geom-pair table: 0 no crash, 1 crash, 2 crash unless the contact
    normal is upright (a wheel on a surface)."""

    def __init__(self, model: mujoco.MjModel, root: int, wheel_bodies: list[int]) -> None:
        mine = model.body_rootid[model.geom_bodyid] == root
        wheel = np.isin(model.geom_bodyid, wheel_bodies)
        kind = np.zeros((model.ngeom, model.ngeom), np.int8)
        kind[np.ix_(mine, ~mine)] = 1
        kind[np.ix_(mine & wheel, ~mine)] = 2
        self.kind = np.maximum(kind, kind.T)
        self._kinds = self.kind.tolist()  # nested lists: a few contacts are looked up faster in Python than numpy

    def crashed(self, data: mujoco.MjData) -> bool:
        """Whether the current contact list holds a crash."""
        n = data.ncon
        if n == 0:
            return False
        contact, kinds = data.contact, self._kinds
        for (first, second), normal_z in zip(contact.geom[:n].tolist(), contact.frame[:n, 2].tolist()):
            kind = kinds[first][second]
            if kind == 1 or (kind == 2 and abs(normal_z) <= SUPPORT_NORMAL_Z):
                return True
        return False
