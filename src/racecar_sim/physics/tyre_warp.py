"""The tyre model and the actuator rate limits for MuJoCo Warp: the compiled CPU callbacks' rules
(physics/tyre_callback.py, tyre_kernels.py) as Warp kernels, computed for every world at once.

MuJoCo Warp calls none of MuJoCo's global callbacks, but each of its models has its own (`Model.callback`), called
at the same points of the step as CPU MuJoCo's. `WarpTyres.install` sets three of them:

- passive (end of the passive forces): per (world, wheel) the tyre force and its contact point, then per (world,
  dof) that force through the point's translational Jacobian added to qfrc_passive, as mj_applyFT adds it on CPU;
- sensor (at the acceleration stage, after the touch sensors): each wheel's normal load copied aside. MuJoCo Warp
  zeroes every sensor at the start of a step, before the passive forces, where CPU MuJoCo keeps the acceleration
  stage's sensors of the previous step: the copy is that previous step's load, the one the CPU callback reads;
- act_dyn (after the actuator forces): act_dot of every `user` dyntype actuator, the setpoint moving towards the
  command at no more than its limits (physics/actuation.py writes them as dynprm: low, high, timestep). CPU MuJoCo
  then integrates act += act_dot dt with the other activations; MuJoCo Warp leaves a `user` activation as it is
  (the callback's to move), so the kernel also takes that Euler step. Nothing reads act between the callback and
  the integration (the forces of this step were computed from the old act before it, as on CPU).

Nothing is set for a model without tyre tables or user actuators: MuJoCo Warp steps it as it did. MuJoCo Warp
computes in float32, so the forces agree with the CPU callback's to float32 rounding.
"""

from __future__ import annotations

from functools import cache
from types import SimpleNamespace
from typing import Any

import mujoco
import numpy as np

from racecar_sim.physics.tyre_callback import HEADER, MAGIC, PACEJKA, STRIDE


def tyre_rows(model: mujoco.MjModel) -> np.ndarray:
    """(wheels, STRIDE) float64: the rows of every tyre table of the model, in table order."""
    rows = []
    for k in range(model.nnumeric):
        start, size = int(model.numeric_adr[k]), int(model.numeric_size[k])
        table = model.numeric_data[start : start + size]
        if size >= HEADER and table[0] == MAGIC:
            wheels = int(table[1])
            rows.append(table[HEADER : HEADER + STRIDE * wheels].reshape(wheels, STRIDE))
    return np.concatenate(rows) if rows else np.zeros((0, STRIDE))


def rate_limited_actuators(model: mujoco.MjModel) -> np.ndarray:
    """The ids of the model's `user` dyntype actuators (the rate-limited setpoints of physics/actuation.py)."""
    return np.flatnonzero(model.actuator_dyntype == mujoco.mjtDyn.mjDYN_USER)


def needs_callbacks(model: mujoco.MjModel) -> bool:
    """Whether the model has tyre tables or rate-limited actuators (what WarpTyres computes)."""
    return len(tyre_rows(model)) > 0 or len(rate_limited_actuators(model)) > 0


class WarpTyres:
    """The tyre forces and actuator rate limits of one MuJoCo Warp model and its worlds (see the module's docstring).

    wp: the warp module; device_model: the mujoco_warp Model (its callbacks are set); model, data: the CPU model and
    the state every world starts from (its touch sensors: the first step's wheel loads); num_worlds: N.
    """

    def __init__(self, wp: Any, device_model: Any, model: mujoco.MjModel, data: mujoco.MjData, num_worlds: int) -> None:
        self._wp, self._kernels = wp, _build_kernels(wp)
        rows = tyre_rows(model)
        user = rate_limited_actuators(model)
        self.num_wheels = len(rows)
        self.num_worlds = num_worlds
        self._sensor_adr = rows[:, 2].astype(np.int64)
        self._loads0 = np.asarray(data.sensordata, np.float64)[self._sensor_adr]
        self._rows = wp.array(rows.astype(np.float32), dtype=float)
        self._bodies = wp.array(rows[:, 0].astype(np.int32), dtype=int)
        self._roots = wp.array(rows[:, 1].astype(np.int32), dtype=int)
        self._sensors = wp.array(self._sensor_adr.astype(np.int32), dtype=int)
        self.loads = wp.array(np.tile(self._loads0, (num_worlds, 1)).astype(np.float32), dtype=float)
        self._force = wp.zeros((num_worlds, self.num_wheels), dtype=wp.vec3)
        self._point = wp.zeros((num_worlds, self.num_wheels), dtype=wp.vec3)
        self._actuators = wp.array(user.astype(np.int32), dtype=int)
        self._act_adr = wp.array(model.actuator_actadr[user].astype(np.int32), dtype=int)
        self._limits = wp.array(model.actuator_dynprm[user, :3].astype(np.float32), dtype=wp.vec3)
        self._timestep = float(model.opt.timestep)
        if self.num_wheels:
            device_model.callback.passive = self._passive
            device_model.callback.sensor = self._sensor
        if len(user):
            device_model.callback.act_dyn = self._act_dyn

    # --- the callbacks MuJoCo Warp calls ----------------------------------------------------------------------
    def _passive(self, m: Any, d: Any) -> None:
        wp, k = self._wp, self._kernels
        wp.launch(
            k.tyre_forces,
            dim=(d.nworld, self.num_wheels),
            inputs=[self._rows, self.loads, d.xpos, d.xmat, d.cvel, d.subtree_com],
            outputs=[self._force, self._point],
        )
        wp.launch(
            k.apply_forces,
            dim=(d.nworld, m.nv),
            inputs=[self._bodies, self._roots, m.body_isdofancestor, d.subtree_com, d.cdof, self._force, self._point],
            outputs=[d.qfrc_passive],
        )

    def _sensor(self, m: Any, d: Any, stage: Any) -> None:
        if stage == mujoco.mjtStage.mjSTAGE_ACC:
            self._wp.launch(
                self._kernels.copy_loads,
                dim=(d.nworld, self.num_wheels),
                inputs=[self._sensors, d.sensordata],
                outputs=[self.loads],
            )

    def _act_dyn(self, m: Any, d: Any) -> None:
        self._wp.launch(
            self._kernels.rate_limit,
            dim=(d.nworld, self._actuators.shape[0]),
            inputs=[self._actuators, self._act_adr, self._limits, self._timestep, d.ctrl],
            outputs=[d.act, d.act_dot],
        )

    # --- host side ------------------------------------------------------------------------------------------
    def reset(self, rows: np.ndarray, sensordata: np.ndarray | None = None) -> None:
        """The chosen worlds' wheel loads for their next step: from `sensordata` (one row per chosen world), or the
        initial state's."""
        if not self.num_wheels:
            return
        host = self.loads.numpy()
        host[rows] = self._loads0 if sensordata is None else np.asarray(sensordata)[:, self._sensor_adr]
        self.loads.assign(host)


@cache
def _build_kernels(wp: Any) -> SimpleNamespace:
    """The Warp kernels (built once per process, compiled by Warp at their first launch and cached on disk)."""
    pacejka = float(PACEJKA)

    @wp.func
    def magic_formula(x: float, b: float, c: float, d: float, e: float) -> float:
        bx = b * x
        return d * wp.sin(c * wp.atan(bx - e * (bx - wp.atan(bx))))

    @wp.kernel
    def tyre_forces(
        rows: wp.array2d(dtype=float),  # type: ignore[valid-type]
        loads: wp.array2d(dtype=float),  # type: ignore[valid-type]
        xpos: wp.array2d(dtype=wp.vec3),  # type: ignore[valid-type]
        xmat: wp.array2d(dtype=wp.mat33),  # type: ignore[valid-type]
        cvel: wp.array2d(dtype=wp.spatial_vector),  # type: ignore[valid-type]
        subtree_com: wp.array2d(dtype=wp.vec3),  # type: ignore[valid-type]
        force: wp.array2d(dtype=wp.vec3),  # type: ignore[valid-type]
        point: wp.array2d(dtype=wp.vec3),  # type: ignore[valid-type]
    ) -> None:
        # a row: body, root body, touch sensor address, radius, spin axis in the body frame (3), model, mu, C_S,
        # B, C, D, E, v_eps_x, v_eps_y, tyre centre in the body frame (3), longitudinal force cap per slip speed
        world, wheel = wp.tid()
        force[world, wheel] = wp.vec3(0.0)
        load = loads[world, wheel]
        if load <= 0.0:
            return
        body = int(rows[wheel, 0])
        rotation = xmat[world, body]
        axis = rotation @ wp.vec3(rows[wheel, 4], rows[wheel, 5], rows[wheel, 6])
        centre = xpos[world, body] + rotation @ wp.vec3(rows[wheel, 16], rows[wheel, 17], rows[wheel, 18])
        norm = wp.sqrt(axis[0] * axis[0] + axis[1] * axis[1])
        if norm < 1.0e-6:
            return  # the wheel lies flat
        across = wp.vec3(axis[0] / norm, axis[1] / norm, 0.0)  # e_y: the axis in the ground plane
        along = wp.vec3(across[1], -across[0], 0.0)  # e_x = e_y x up
        # contact point: the rim's lowest point, below the centre across the axis (up minus its part along the axis)
        down = wp.vec3(-axis[2] * axis[0], -axis[2] * axis[1], 1.0 - axis[2] * axis[2])
        contact = centre - rows[wheel, 3] * down / wp.length(down)
        # velocities of the centre and of the wheel's material at the contact point (cvel: about subtree_com)
        spin = wp.spatial_top(cvel[world, body])
        linear = wp.spatial_bottom(cvel[world, body])
        origin = subtree_com[world, int(rows[wheel, 1])]
        v_centre = linear + wp.cross(spin, centre - origin)
        v_contact = linear + wp.cross(spin, contact - origin)
        speed = wp.abs(wp.dot(v_centre, along))
        slip_x, slip_y = wp.dot(v_contact, along), wp.dot(v_contact, across)
        rolling = wp.abs(wp.dot(v_centre, along) - slip_x)  # the rim's speed, omega r
        kappa = -slip_x / wp.max(wp.max(speed, rolling), rows[wheel, 14])
        alpha = wp.atan(-slip_y / wp.max(speed, rows[wheel, 15]))
        mu = rows[wheel, 8]
        fx = float(0.0)  # noqa: UP018 (a Warp variable a branch or loop changes)
        fy = float(0.0)  # noqa: UP018 (a Warp variable a branch or loop changes)
        peak = float(0.0)  # noqa: UP018 (a Warp variable a branch or loop changes)
        if rows[wheel, 7] == pacejka:
            b, c, d, e = rows[wheel, 10], rows[wheel, 11], rows[wheel, 12], rows[wheel, 13]
            fx = load * magic_formula(kappa, b, c, d, e)
            fy = load * magic_formula(alpha, b, c, d, e)
            peak = load * d
        else:
            stiffness = mu * rows[wheel, 9] * load
            fx = stiffness * kappa
            fy = stiffness * alpha
            peak = mu * load
        # the wheel's spin is integrated explicitly: no stiffer than its inertia allows in one step
        cap = rows[wheel, 19]
        if wp.abs(fx) > cap * wp.abs(slip_x):
            fx = -cap * slip_x
        total = wp.sqrt(fx * fx + fy * fy)
        if total > peak:
            fx = fx * peak / total
            fy = fy * peak / total
        force[world, wheel] = fx * along + fy * across
        point[world, wheel] = contact

    @wp.kernel
    def apply_forces(
        bodies: wp.array(dtype=int),  # type: ignore[valid-type]
        roots: wp.array(dtype=int),  # type: ignore[valid-type]
        isdofancestor: wp.array2d(dtype=int),  # type: ignore[valid-type]
        subtree_com: wp.array2d(dtype=wp.vec3),  # type: ignore[valid-type]
        cdof: wp.array2d(dtype=wp.spatial_vector),  # type: ignore[valid-type]
        force: wp.array2d(dtype=wp.vec3),  # type: ignore[valid-type]
        point: wp.array2d(dtype=wp.vec3),  # type: ignore[valid-type]
        qfrc: wp.array2d(dtype=float),  # type: ignore[valid-type]
    ) -> None:
        # mj_applyFT's rule: qfrc += jacp(point, body)^T force, jacp = cdof_lin + cdof_ang x (point - subtree_com)
        world, dof = wp.tid()
        axis = cdof[world, dof]
        total = float(0.0)  # noqa: UP018 (a Warp variable a branch or loop changes)
        for wheel in range(bodies.shape[0]):
            if isdofancestor[bodies[wheel], dof] != 0:
                offset = point[world, wheel] - subtree_com[world, roots[wheel]]
                jacp = wp.spatial_bottom(axis) + wp.cross(wp.spatial_top(axis), offset)
                total += wp.dot(jacp, force[world, wheel])
        qfrc[world, dof] = qfrc[world, dof] + total

    @wp.kernel
    def copy_loads(
        sensors: wp.array(dtype=int),  # type: ignore[valid-type]
        sensordata: wp.array2d(dtype=float),  # type: ignore[valid-type]
        loads: wp.array2d(dtype=float),  # type: ignore[valid-type]
    ) -> None:
        world, wheel = wp.tid()
        loads[world, wheel] = sensordata[world, sensors[wheel]]

    @wp.kernel
    def rate_limit(
        actuators: wp.array(dtype=int),  # type: ignore[valid-type]
        act_adr: wp.array(dtype=int),  # type: ignore[valid-type]
        limits: wp.array(dtype=wp.vec3),  # type: ignore[valid-type]
        timestep: float,
        ctrl: wp.array2d(dtype=float),  # type: ignore[valid-type]
        act: wp.array2d(dtype=float),  # type: ignore[valid-type]
        act_dot: wp.array2d(dtype=float),  # type: ignore[valid-type]
    ) -> None:
        # dynprm: low, high, timestep; the CPU callback's min(max((ctrl - act) / dt, low), high), then CPU MuJoCo's
        # Euler step of the activation (MuJoCo Warp takes none for a user activation)
        world, k = wp.tid()
        adr = act_adr[k]
        limit = limits[k]
        rate = wp.min(wp.max((ctrl[world, actuators[k]] - act[world, adr]) / limit[2], limit[0]), limit[1])
        act_dot[world, adr] = rate
        act[world, adr] = act[world, adr] + rate * timestep

    return SimpleNamespace(
        tyre_forces=tyre_forces, apply_forces=apply_forces, copy_loads=copy_loads, rate_limit=rate_limit
    )


__all__ = ["WarpTyres", "needs_callbacks", "rate_limited_actuators", "tyre_rows"]
