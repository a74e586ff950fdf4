"""The car's Hokuyo over a batch of worlds: ray origins from the batch's base poses, the compiled 2-D wall cast
(sensors/raycast/batch.py), the single car's RayCaster where that cannot answer, and per-world noise taken as
LidarPublisher.scan takes it (its NoiseTable, per (seed, stamp))."""

from __future__ import annotations

import copy
import threading

import mujoco
import numpy as np

from racecar_sim.physics import COLLISION_GROUP
from racecar_sim.sensors.lidar import LidarPublisher
from racecar_sim.sensors.raycast import RayCaster
from racecar_sim.sensors.raycast.batch import BatchFrames, BatchWallCaster


class BatchLidar:
    """Scans of one car's lidar in N copies of a world, given each world's root pose (qpos[root:root+7])."""

    def __init__(self, lidar: LidarPublisher, model: mujoco.MjModel, root_body: int, root_qpos: int) -> None:
        self.spec, self.fan, self.noise = lidar.spec, lidar.fan, lidar.noise
        self.root_qpos, self._lidar = root_qpos, lidar
        caster = lidar.caster
        self.walls = BatchWallCaster(caster.static, self.fan, caster._has_moving)
        mount = lidar.mount  # the ray origin and axes from each world's chassis pose, as the single car's
        if mount is None or mount.qpos_adr != root_qpos:
            raise ValueError("the batch lidar needs the laser welded to the car's root body")
        self.mount = mount
        self._model, self._root_body = model, root_body
        self._local = threading.local()  # per thread: a model copy, a posed MjData and a RayCaster (fallback)

    def _fallback_caster(self) -> tuple[mujoco.MjModel, mujoco.MjData, RayCaster]:
        local = self._local
        if not hasattr(local, "caster"):
            model = copy.copy(self._model)  # MujocoRays hides the car's geoms in its model while casting
            data = mujoco.MjData(model)
            local.caster = (model, data, RayCaster(model, data, self.fan, self._root_body, COLLISION_GROUP))
        return local.caster

    def true_ranges(self, qpos: np.ndarray) -> np.ndarray:
        """Noise-free ranges (N, beams), inf where nothing is within range, for worlds at `qpos` (N, nq)."""
        origin, axes = self.mount.poses(qpos)
        ranges, fallback = self.walls.cast(BatchFrames.from_poses(origin, axes, self.fan))
        if len(fallback):
            model, data, caster = self._fallback_caster()
            for i in fallback.tolist():
                data.qpos[:] = qpos[i]
                mujoco.mj_kinematics(model, data)
                ranges[i] = caster.cast(origin[i], axes[i])
        return ranges

    def scans(self, qpos: np.ndarray, seeds: np.ndarray, stamps_ns: np.ndarray) -> np.ndarray:
        """The published ranges (float32, N x beams) of scans stamped `stamps_ns` (N,) in worlds seeded `seeds`."""
        return self.publish(self.true_ranges(qpos), seeds, stamps_ns)

    def publish(self, ranges: np.ndarray, seeds: np.ndarray, stamps_ns: np.ndarray) -> np.ndarray:
        """The published ranges (float32, N x beams) of true ranges (N x beams, inf: no hit) cast elsewhere (a Warp
        device): the single car's noise, clamp and float32 rule, compiled."""
        return self._lidar.publish(ranges, seeds, stamps_ns)
