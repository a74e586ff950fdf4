"""Where a laser's rays start and point, read straight from the pose of the free body it is welded to.

A scan needs the ray origin and the sensor axes at the current qpos. Running MuJoCo's kinematics on a posed copy
of the data gives them for any mount; for the usual one - the laser on the car's chassis, which is the free
body itself - they are a fixed offset from the body's pose in qpos, computed here in a few float operations.
`pose` (one car, Python floats) and `poses` (a batch, numpy) do the same operations in the same order, so they
agree bit for bit.
"""

from __future__ import annotations

import weakref
from collections.abc import Sequence
from typing import overload

import mujoco
import numpy as np

# each model's bodies posed at qpos0 (mj_kinematics of a fresh MjData): what every mount of a fleet reads, made once
_AT_QPOS0: weakref.WeakKeyDictionary[mujoco.MjModel, mujoco.MjData] = weakref.WeakKeyDictionary()


class LaserMount:
    """The ray origin and axes in the frame of the free body the laser is welded to (see the module doc)."""

    def __init__(self, local_origin: np.ndarray, local_axes: np.ndarray, qpos_adr: int) -> None:
        self.local_origin = np.asarray(local_origin, float)
        self.local_axes = np.asarray(local_axes, float)
        self.qpos_adr = qpos_adr
        self._origin = self.local_origin.tolist()
        self._axes = self.local_axes.tolist()

    @classmethod
    def of(cls, model: mujoco.MjModel, site: int, offset: np.ndarray, turn: np.ndarray) -> LaserMount | None:
        """The mount of the ray origin `offset` (in the site's frame) with axes `turn` (site from sensor) on
        `site`, if the site is welded to a body with a free joint; else None (use kinematics)."""
        body = int(model.body_weldid[model.site_bodyid[site]])
        if body == 0 or model.body_jntnum[body] != 1:
            return None
        joint = int(model.body_jntadr[body])
        if model.jnt_type[joint] != mujoco.mjtJoint.mjJNT_FREE:
            return None
        data = _posed_at_qpos0(model)
        body_rot = data.xmat[body].reshape(3, 3)
        site_rot = data.site_xmat[site].reshape(3, 3)
        local_origin = body_rot.T @ (data.site_xpos[site] + site_rot @ offset - data.xpos[body])
        return cls(local_origin, body_rot.T @ (site_rot @ turn), int(model.jnt_qposadr[joint]))

    def pose(self, qpos: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Ray origin (3,) and sensor axes (3, 3; world from sensor) at `qpos`."""
        origin, axes = self.pose_lists(qpos)
        return np.array(origin), np.array(axes)

    def pose_lists(self, qpos: np.ndarray) -> tuple[list[float], list[list[float]]]:
        """pose() as Python floats: the ray origin [x, y, z] and the sensor axes' rows (the same numbers)."""
        a = self.qpos_adr
        px, py, pz, w, x, y, z = qpos[a : a + 7].tolist()
        (r00, r01, r02), (r10, r11, r12), (r20, r21, r22) = _rotation(w, x, y, z)
        o0, o1, o2 = self._origin
        (a00, a01, a02), (a10, a11, a12), (a20, a21, a22) = self._axes
        origin = [
            px + (r00 * o0 + r01 * o1 + r02 * o2),
            py + (r10 * o0 + r11 * o1 + r12 * o2),
            pz + (r20 * o0 + r21 * o1 + r22 * o2),
        ]
        axes = [
            [r00 * a00 + r01 * a10 + r02 * a20, r00 * a01 + r01 * a11 + r02 * a21, r00 * a02 + r01 * a12 + r02 * a22],
            [r10 * a00 + r11 * a10 + r12 * a20, r10 * a01 + r11 * a11 + r12 * a21, r10 * a02 + r11 * a12 + r12 * a22],
            [r20 * a00 + r21 * a10 + r22 * a20, r20 * a01 + r21 * a11 + r22 * a21, r20 * a02 + r21 * a12 + r22 * a22],
        ]
        return origin, axes

    def poses(self, qpos: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """pose() for every row of `qpos` (N, nq): origins (N, 3) and axes (N, 3, 3)."""
        a = self.qpos_adr
        root = qpos[:, a : a + 7]
        r = _rotation(*root[:, 3:].T)
        lo, la = self.local_origin, self.local_axes
        origin = np.stack([root[:, i] + (r[i][0] * lo[0] + r[i][1] * lo[1] + r[i][2] * lo[2]) for i in range(3)], -1)
        axes = np.stack(
            [
                np.stack([r[i][0] * la[0, j] + r[i][1] * la[1, j] + r[i][2] * la[2, j] for j in range(3)], -1)
                for i in range(3)
            ],
            1,
        )
        return origin, axes


def _posed_at_qpos0(model: mujoco.MjModel) -> mujoco.MjData:
    """An MjData of `model` posed by mj_kinematics at qpos0, made once per model (read only: a fleet's N lasers
    share it instead of making N MjData of the N-car model)."""
    data = _AT_QPOS0.get(model)
    if data is None:
        data = _AT_QPOS0[model] = mujoco.MjData(model)
        mujoco.mj_kinematics(model, data)
    return data


@overload
def _rotation(w: float, x: float, y: float, z: float) -> Sequence[Sequence[float]]: ...
@overload
def _rotation(w: np.ndarray, x: np.ndarray, y: np.ndarray, z: np.ndarray) -> Sequence[Sequence[np.ndarray]]: ...
def _rotation(
    w: float | np.ndarray, x: float | np.ndarray, y: float | np.ndarray, z: float | np.ndarray
) -> Sequence[Sequence[float | np.ndarray]]:
    """The rotation matrix (rows of entries) of a unit quaternion: floats, or arrays for many."""
    return [
        [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
        [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
        [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
    ]
