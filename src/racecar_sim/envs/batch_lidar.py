"""The car's Hokuyo over a batch of worlds: ray origins from the batch's base poses, the 2-D wall cast as array
code (sensors/raycast/batch.py), the single car's RayCaster where that cannot answer, and per-world noise drawn
exactly as LidarPublisher.scan draws it (sample_stream(seed, "scan", stamp); the generators set up as array code
over the batch by batch_noise.py)."""

from __future__ import annotations

import copy
import threading

import mujoco
import numpy as np

from racecar_sim.envs.batch_noise import ScanNoise
from racecar_sim.physics import COLLISION_GROUP
from racecar_sim.sensors.lidar import LidarPublisher
from racecar_sim.sensors.raycast import RayCaster
from racecar_sim.sensors.raycast.batch import BatchFrames, BatchWallCaster


def quat_to_matrices(q: np.ndarray) -> np.ndarray:
    """(N, 4) (w, x, y, z) unit quaternions -> (N, 3, 3) rotation matrices."""
    w, x, y, z = q.T
    return np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y),
                     2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x),
                     2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], -1).reshape(-1, 3, 3)


class BatchLidar:
    """Scans of one car's lidar in N copies of a world, given each world's root pose (qpos[root:root+7])."""

    def __init__(self, lidar: LidarPublisher, model: mujoco.MjModel, root_body: int, root_qpos: int) -> None:
        self.spec, self.fan, self.noise = lidar.spec, lidar.fan, lidar.noise
        self.noise_stream, self.root_qpos = lidar.noise_stream, root_qpos
        caster = lidar.caster
        self.walls = BatchWallCaster(caster.static, self.fan, caster._has_moving)
        # the ray origin and axes in the root body's frame (the sensor is welded to it)
        pose = mujoco.MjData(model)
        mujoco.mj_kinematics(model, pose)
        site = lidar._site
        if model.body_weldid[model.site_bodyid[site]] != model.body_weldid[root_body]:
            raise ValueError("the batch lidar needs the laser welded to the car's root body")
        root_rot = pose.xmat[root_body].reshape(3, 3)
        site_rot = pose.site_xmat[site].reshape(3, 3)
        self.local_origin = root_rot.T @ (pose.site_xpos[site] + site_rot @ lidar._offset - pose.xpos[root_body])
        self.local_axes = root_rot.T @ (site_rot @ lidar._turn)
        self._model, self._root_body = model, root_body
        self._noise = ScanNoise(self.noise_stream, lidar.spec.noise_mean, lidar.spec.noise_stddev, self.fan.count)
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
        root = qpos[:, self.root_qpos:self.root_qpos + 7]
        rot = quat_to_matrices(root[:, 3:])
        origin = root[:, :3] + rot @ self.local_origin
        axes = rot @ self.local_axes
        ranges, fallback = self.walls.cast(BatchFrames.from_poses(origin, axes, self.fan))
        if len(fallback):
            model, data, caster = self._fallback_caster()
            for i in fallback.tolist():
                data.qpos[:] = qpos[i]
                mujoco.mj_kinematics(model, data)
                ranges[i] = caster.cast(origin[i], axes[i])
        return ranges

    def noise_states(self, seeds: np.ndarray, stamps_ns: np.ndarray) -> list[tuple[int, int]] | None:
        """The noise generators' states of scans stamped `stamps_ns` (N,) in worlds seeded `seeds` (None: no noise)."""
        return self._noise.states(seeds, stamps_ns) if self.noise else None

    def scans(self, qpos: np.ndarray, seeds: np.ndarray, stamps_ns: np.ndarray,
              noise_states: list[tuple[int, int]] | None = None) -> np.ndarray:
        """The published ranges (float32, N x beams) of scans stamped `stamps_ns` (N,), with each world's noise
        (from `noise_states` when given: noise_states(seeds, stamps_ns), computed once for a whole batch)."""
        ranges = self.true_ranges(qpos)
        hit = np.isfinite(ranges)
        spec = self.spec
        if self.noise:
            self._noise.add(ranges, noise_states if noise_states is not None else self.noise_states(seeds, stamps_ns))
        ranges = np.where(hit, np.clip(ranges, spec.range_min, spec.range_max), np.inf)
        return ranges.astype(np.float32)
