"""One MjData posed at the live qpos, shared by every sensor of a simulation: where every sensor samples.

The sampling point, for every sensor: the state at the end of the last physics step (the live qpos, qvel, act and
controls after mj_step), as Gazebo's sensors update after the world's step. Ray casts read the bodies posed there
(`update`: mj_kinematics); MuJoCo's own sensors (an IMU's accelerometer and gyro) and body velocities (p3d) read the
whole forward pass there (`forward`: mj_forward of the same state, in a second shared copy).

After mj_step the live data's positions (geom_xpos, site_xpos) describe the start of the last step, while qpos holds
its end; a sensor that needs where the bodies are now poses a private MjData from the live qpos with mj_kinematics.
Every car's lidar scans at the same tick with the same qpos, so a fleet shares one posed MjData: it is posed again
only when qpos or the mocap poses changed since the last time (one mj_kinematics per tick for the whole fleet, not
one per car, and one MjData in memory, not one per car).
"""

from __future__ import annotations

import weakref
from typing import TYPE_CHECKING

import mujoco
import numpy as np

if TYPE_CHECKING:
    from racecar_sim.sensors.fleet_scans import FleetScans


class SharedPose:
    """An MjData of `model` posed at the qpos and mocap poses of a live MjData (see the module doc)."""

    _shared: weakref.WeakKeyDictionary[mujoco.MjData, SharedPose] = weakref.WeakKeyDictionary()

    def __init__(self, model: mujoco.MjModel) -> None:
        self.model = model
        self.pose = mujoco.MjData(model)
        self._key: tuple[bytes, bytes, bytes] | None = None
        self.posed = 0  # how many times it was posed (mj_kinematics calls)
        self._forwarded: mujoco.MjData | None = None  # made at the first forward() (an IMU, a p3d)
        self._forward_key: tuple[float, bytes] | None = None
        self._state = mujoco.mjtState.mjSTATE_INTEGRATION
        self._buffer = np.empty(mujoco.mj_stateSize(model, self._state))
        # the lidars' one-call scans of this simulation (sensors/fleet_scans.py), held weakly: its lidars hold it, and
        # through this class's registry it would keep a simulation dropped without close() alive
        self.fleet_scans: weakref.ref[FleetScans] | None = None

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

    def forward(self, data: mujoco.MjData) -> mujoco.MjData:
        """An MjData holding `data`'s whole state (time, qpos, qvel, act, controls, applied forces, mocap), forwarded:
        positions, velocities, accelerations and sensordata at the end of the last step (again only if it changed)."""
        mujoco.mj_getState(self.model, data, self._buffer, self._state)
        key = (data.time, self._buffer.tobytes())
        if self._forwarded is None:
            self._forwarded = mujoco.MjData(self.model)
        if key != self._forward_key:
            mujoco.mj_setState(self.model, self._forwarded, self._buffer, self._state)
            mujoco.mj_forward(self.model, self._forwarded)
            self._forward_key = key
        return self._forwarded
