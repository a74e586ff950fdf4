"""One MjData posed at the live qpos, shared by every sensor of a simulation.

After mj_step the live data's positions (geom_xpos, site_xpos) describe the start of the last step, while qpos holds
its end; a sensor that needs where the bodies are now poses a private MjData from the live qpos with mj_kinematics.
Every car's lidar scans at the same tick with the same qpos, so a fleet shares one posed MjData: it is posed again
only when qpos or the mocap poses changed since the last time (one mj_kinematics per tick for the whole fleet, not
one per car, and one MjData in memory, not one per car).
"""

from __future__ import annotations

import weakref

import mujoco


class SharedPose:
    """An MjData of `model` posed at the qpos and mocap poses of a live MjData (see the module doc)."""

    _shared: weakref.WeakKeyDictionary[mujoco.MjData, SharedPose] = weakref.WeakKeyDictionary()

    def __init__(self, model: mujoco.MjModel) -> None:
        self.model = model
        self.pose = mujoco.MjData(model)
        self._key: tuple[bytes, bytes, bytes] | None = None
        self.posed = 0  # how many times it was posed (mj_kinematics calls)

    @classmethod
    def of(cls, model: mujoco.MjModel, data: mujoco.MjData) -> SharedPose:
        """The pose shared by every sensor reading the live `data` of `model` (a new one for a recompiled model)."""
        found = cls._shared.get(data)
        if found is None or found.model is not model:
            found = cls._shared[data] = cls(model)
        return found

    def update(self, data: mujoco.MjData) -> mujoco.MjData:
        """The posed MjData at `data`'s qpos and mocap poses (posed again only if they changed)."""
        key = (data.qpos.tobytes(), data.mocap_pos.tobytes(), data.mocap_quat.tobytes())
        pose = self.pose
        if key != self._key:
            pose.qpos[:] = data.qpos
            pose.mocap_pos[:] = data.mocap_pos
            pose.mocap_quat[:] = data.mocap_quat
            mujoco.mj_kinematics(self.model, pose)
            self._key = key
            self.posed += 1
        return pose
