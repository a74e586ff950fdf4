"""Read the car's state from, and write commands to, the MuJoCo data: the one door other layers use."""

from __future__ import annotations

import mujoco
import numpy as np

from racecar_sim.physics.builder import ROOT_JOINT


class CarState:
    """Named access to joints, actuators and the base_link body of the car in a compiled model."""

    def __init__(self, model: mujoco.MjModel, data: mujoco.MjData, root_link: str) -> None:
        self.model, self.data = model, data
        self._base = model.body(root_link).id
        self._root_qpos = model.jnt_qposadr[model.joint(ROOT_JOINT).id]
        self._vel = np.zeros(6)

    def set_command(self, actuator: str, value: float) -> None:
        """Set the setpoint of an actuator (and of its companion I-term actuator, if any)."""
        for name in (actuator, f"{actuator}/i_term"):
            aid = mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_ACTUATOR, name)
            if aid >= 0:
                self.data.ctrl[self.model.actuator_ctrladr[aid]] = value

    def joint_indices(self, joints: list[str]) -> tuple[np.ndarray, np.ndarray]:
        """qpos and dof addresses of hinge/slide joints, for joint_state()."""
        ids = [self.model.joint(j).id for j in joints]
        return self.model.jnt_qposadr[ids].copy(), self.model.jnt_dofadr[ids].copy()

    def joint_state(self, qpos_adr: np.ndarray, dof_adr: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Positions, velocities and actuator efforts of the joints at those addresses."""
        d = self.data
        return d.qpos[qpos_adr].copy(), d.qvel[dof_adr].copy(), d.qfrc_actuator[dof_adr].copy()

    def base_pose(self) -> tuple[np.ndarray, np.ndarray]:
        """World position and (w, x, y, z) orientation of the base_link frame."""
        q = self.data.qpos[self._root_qpos:self._root_qpos + 7]
        return q[:3].copy(), q[3:].copy()

    def base_velocity(self, local: bool = False) -> tuple[np.ndarray, np.ndarray]:
        """Linear and angular velocity of the base_link origin, in the world frame (or the body frame)."""
        mujoco.mj_objectVelocity(self.model, self.data, mujoco.mjtObj.mjOBJ_XBODY, self._base, self._vel, int(local))
        return self._vel[3:].copy(), self._vel[:3].copy()

    def reset(self, qpos0: np.ndarray) -> None:
        """Back to the initial state, the car at its spawn pose."""
        mujoco.mj_resetData(self.model, self.data)
        self.data.qpos[:] = qpos0
        mujoco.mj_forward(self.model, self.data)
