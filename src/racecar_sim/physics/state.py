"""Read the car's state from, and write commands to, the MuJoCo data: the one door other layers use."""

from __future__ import annotations

import mujoco
import numpy as np

from racecar_sim.core.names import CarNames
from racecar_sim.core.transforms import quat_from_axis_angle
from racecar_sim.physics.builder import ROOT_JOINT

_XBODY = int(mujoco.mjtObj.mjOBJ_XBODY)  # as a plain int: MuJoCo's functions take it, and convert it faster


class CarState:
    """Named access to joints, actuators and the base_link body of the car in a compiled model."""

    def __init__(
        self, model: mujoco.MjModel, data: mujoco.MjData, root_link: str, names: CarNames = CarNames()
    ) -> None:
        self.names, self.root_link = names, root_link
        self._vel = np.zeros(6)
        self._handed_out: list[tuple[list[str], np.ndarray, np.ndarray]] = []  # joint_indices() answers
        self._disabled: set[str] = set()  # controllers whose actuators apply no force (enable_actuator)
        self.rebind(model, data)

    def rebind(self, model: mujoco.MjModel, data: mujoco.MjData) -> None:
        """Use a recompiled model and its data (a model was spawned or deleted): every id and address is looked up
        again, and the address arrays joint_indices() handed out are updated in place, so nodes holding them go on."""
        self.model, self.data = model, data
        # the arrays the per-tick reads and writes use, as views made once (MjData makes a new view at every access)
        self._qpos, self._qvel, self._ctrl, self._qfrc_actuator = data.qpos, data.qvel, data.ctrl, data.qfrc_actuator
        self._base = model.body(self.names.mj(self.root_link)).id
        root = model.joint(self.names.mj(ROOT_JOINT)).id
        self._root_qpos, self._root_dof = int(model.jnt_qposadr[root]), int(model.jnt_dofadr[root])
        self._actuators: dict[str, list[int]] = {}
        self._actuator_ids: dict[str, list[int]] = {}
        for joints, qpos_adr, dof_adr in self._handed_out:
            qpos_adr[:], dof_adr[:] = self._joint_addresses(joints)
        self._compiled_prm = (model.actuator_gainprm.copy(), model.actuator_biasprm.copy())  # for enable_actuator
        for actuator in list(self._disabled):  # a stopped controller stays without effort in the recompiled model
            self.enable_actuator(actuator, False)

    def set_command(self, actuator: str, value: float) -> None:
        """Set the setpoint of an actuator (and of its companion I-term actuator, if any)."""
        ctrl = self._ctrl
        for adr in self._actuators.get(actuator) or self.actuator_ctrl(actuator):
            ctrl[adr] = value

    def actuator_ctrl(self, actuator: str) -> list[int]:
        """ctrl addresses of a controller's actuator and its I-term companion (looked up once)."""
        if actuator not in self._actuators:
            ids = [
                mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_ACTUATOR, self.names.mj(name))
                for name in (actuator, f"{actuator}/i_term")
            ]
            self._actuators[actuator] = [int(self.model.actuator_ctrladr[i]) for i in ids if i >= 0]
        return self._actuators[actuator]

    def actuator_ids(self, actuator: str) -> list[int]:
        """MuJoCo ids of a controller's actuator and of its I-term companion, if it has one (looked up once per
        model: reset() re-enables every controller and must stay cheap)."""
        ids = self._actuator_ids.get(actuator)
        if ids is None:
            found = [
                mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_ACTUATOR, self.names.mj(name))
                for name in (actuator, f"{actuator}/i_term")
            ]
            ids = self._actuator_ids[actuator] = [i for i in found if i >= 0]
        return ids

    def enable_actuator(self, actuator: str, enabled: bool) -> None:
        """Let a controller's actuators apply force, or make them apply none from the next step on: their gain and
        bias parameters are zeroed in the model (force = gain * ctrl + bias = 0 whatever ctrl, the state and the
        activations are) and put back from the compiled values; nothing is recompiled."""
        ids = self.actuator_ids(actuator)
        gain, bias = self._compiled_prm
        if enabled:
            self._disabled.discard(actuator)
        else:
            self._disabled.add(actuator)
        self.model.actuator_gainprm[ids] = gain[ids] if enabled else 0.0
        self.model.actuator_biasprm[ids] = bias[ids] if enabled else 0.0

    def joint_indices(self, joints: list[str]) -> tuple[np.ndarray, np.ndarray]:
        """qpos and dof addresses of hinge/slide joints, for joint_state(); kept up to date by rebind()."""
        qpos_adr, dof_adr = self._joint_addresses(joints)
        self._handed_out.append((list(joints), qpos_adr, dof_adr))
        return qpos_adr, dof_adr

    def _joint_addresses(self, joints: list[str]) -> tuple[np.ndarray, np.ndarray]:
        ids = [self.model.joint(self.names.mj(j)).id for j in joints]
        # as numpy's own index type: indexing with MuJoCo's int32 addresses costs several times more
        return self.model.jnt_qposadr[ids].astype(np.intp), self.model.jnt_dofadr[ids].astype(np.intp)

    def joint_state(self, qpos_adr: np.ndarray, dof_adr: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Positions, velocities and actuator efforts of the joints at those addresses (new arrays: indexing with an
        address array copies)."""
        return self._qpos[qpos_adr], self._qvel[dof_adr], self._qfrc_actuator[dof_adr]

    def base_pose(self) -> tuple[np.ndarray, np.ndarray]:
        """World position and (w, x, y, z) orientation of the base_link frame."""
        q = self.data.qpos[self._root_qpos : self._root_qpos + 7]
        return q[:3].copy(), q[3:].copy()

    def base_velocity(self, local: bool = False) -> tuple[np.ndarray, np.ndarray]:
        """Linear and angular velocity of the base_link origin, in the world frame (or the body frame)."""
        mujoco.mj_objectVelocity(self.model, self.data, _XBODY, self._base, self._vel, int(local))
        return self._vel[3:].copy(), self._vel[:3].copy()

    def base_odometry(self, local: bool = False) -> list[float]:
        """base_pose() and base_velocity() in one list of Python floats: x, y, z, qw, qx, qy, qz, vx, vy, vz, wx, wy,
        wz (the same numbers, for a node that builds messages of them)."""
        mujoco.mj_objectVelocity(self.model, self.data, _XBODY, self._base, self._vel, int(local))
        adr = self._root_qpos
        angular_linear = self._vel.tolist()
        return self._qpos[adr : adr + 7].tolist() + angular_linear[3:] + angular_linear[:3]

    @property
    def body_id(self) -> int:
        """MuJoCo id of the car's root body (base_link)."""
        return self._base

    def set_base_pose(self, x: float, y: float, z: float, yaw: float) -> None:
        """Put base_link at (x, y, z) facing `yaw`, at rest (the caller runs mj_forward)."""
        adr, dof = self._root_qpos, self._root_dof
        self.data.qpos[adr : adr + 3] = (x, y, z)
        self.data.qpos[adr + 3 : adr + 7] = quat_from_axis_angle((0.0, 0.0, 1.0), yaw)
        self.data.qvel[dof : dof + 6] = 0.0

    def reset(self, qpos0: np.ndarray) -> None:
        """Back to the initial state, every car at its spawn pose (resets the whole MjData)."""
        mujoco.mj_resetData(self.model, self.data)
        self.data.qpos[:] = qpos0
        mujoco.mj_forward(self.model, self.data)
