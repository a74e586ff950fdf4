"""The GPU path of DriveBatch: N copies of the sim's MuJoCo model stepped by MuJoCo Warp (the `[gpu]` extra:
mujoco-warp, warp-lang), on a CUDA GPU, or on Warp's CPU device when asked for explicitly (for tests).

WarpWorlds holds the worlds on the Warp device; the batch puts states and controls in from host arrays, steps,
and reads back what it needs after a control step (qpos, qvel, the car body's pose, the contacts for the crash
check). On CUDA one `step(nsteps)` is a CUDA graph captured once per nsteps and replayed.

MuJoCo Warp computes in float32, so the worlds agree with CPU MuJoCo to ~1e-4 m over a second of driving
(tests/test_envs_batch_warp.py), not bit for bit as the CPU batch does.

What the sim's model needs adapting: mujoco-warp 4.0.0 has no `pid` gain type (the ros_control controllers'
actuators, control/controllers.py). A pid actuator with one setpoint input and no integral or slew state is a
fixed-gain actuator with the same affine bias (force = kp u_pos + kv u_vel - kp l - kv v), so the Warp copy of the
model uses that; any other pid actuator raises ConfigError. And it has no auto-reset of a diverged state, so the
copy drops the disable-autoreset flag (the sim sets it) that mujoco-warp rejects. A vehicle set's tyre model and
actuator rate limits, CPU MuJoCo callbacks that MuJoCo Warp never calls, run as Warp kernels in the Warp model's own
callbacks (physics/tyre_warp.py), with each world's wheel loads kept on the device.
"""

from __future__ import annotations

import copy
from typing import Any

import mujoco
import numpy as np

from racecar_sim.core.errors import ConfigError
from racecar_sim.physics.tyre_warp import WarpTyres, needs_callbacks

GPU_HINT = (
    "install the [gpu] extra (pip install 'racecar-sim[gpu]': mujoco-warp, warp-lang) on a machine with a CUDA GPU"
)
WARP_DEVICES = {"warp": "cuda", "warp-cpu": "cpu"}  # DriveBatch's device names -> Warp devices
NCONMAX = 64  # contacts allocated per world: the car on the ground has 4 to 8; walls and other cars add a few
_PID_INPUTS = {1: 1, 2: 2, 4: None}  # ctrlspec (mjINPUT_POS, _VEL, _FF) -> biasprm index of its gain (ff: gain 1)


def _import_warp(device: str) -> Any:
    try:
        import mujoco_warp
        import warp
    except ImportError:
        raise ConfigError(f"DriveBatch device={device!r} needs MuJoCo Warp: {GPU_HINT}") from None
    # not Warp's banner nor a line per kernel module loaded (Warp 1.19 has log_level; its old config.quiet is gone)
    warp.config.log_level = warp.LOG_WARNING
    warp.init()
    return mujoco_warp


def warp_model(model: mujoco.MjModel) -> mujoco.MjModel:
    """A copy of `model` that mujoco-warp can load: pid actuators become equivalent fixed-gain ones, sleeping off."""
    model = copy.copy(model)
    # MuJoCo Warp never resets a diverged world (a NaN state stays NaN), so it refuses a model that asks not to
    model.opt.disableflags &= ~int(mujoco.mjtDisableBit.mjDSBL_AUTORESET)
    # the CPU model sleeps only to place static geoms once (physics.builder; no tree ever sleeps): Warp supports no
    # never-sleep policy, and places geoms on the GPU anyway, so sleeping is off there (the same dynamics)
    model.opt.enableflags &= ~int(mujoco.mjtEnableBit.mjENBL_SLEEP)
    model.tree_sleep_policy[:] = mujoco.mjtSleepPolicy.mjSLEEP_AUTO
    pid = np.flatnonzero(model.actuator_gaintype == mujoco.mjtGain.mjGAIN_PID)
    for i in pid.tolist():
        spec = int(model.actuator_ctrlspec[i])
        stateful = model.actuator_dyntype[i] != mujoco.mjtDyn.mjDYN_NONE or model.actuator_gainprm[i, 0] != 0.0
        if spec not in _PID_INPUTS or stateful or model.actuator_biastype[i] != mujoco.mjtBias.mjBIAS_AFFINE:
            raise ConfigError(
                f"actuator '{model.actuator(i).name}': MuJoCo Warp runs no pid actuator with integral "
                "or slew state or several setpoint inputs; use device='cpu' or drop the controller's "
                "i gain"
            )
        index = _PID_INPUTS[spec]
        gain = 1.0 if index is None else -model.actuator_biasprm[i, index]
        model.actuator_gaintype[i] = mujoco.mjtGain.mjGAIN_FIXED
        model.actuator_gainprm[i] = 0.0
        model.actuator_gainprm[i, 0] = gain
        model.actuator_ctrlspec[i] = 0
    return model


class WarpWorlds:
    """N copies of a MuJoCo model and its state on a Warp device, stepped together by MuJoCo Warp.

    model, data: the sim's model and an initial state (every world starts from it); device: "warp" (CUDA) or
    "warp-cpu" (Warp's CPU device: slow, for tests); nconmax: contacts allocated per world.
    """

    def __init__(
        self, model: mujoco.MjModel, data: mujoco.MjData, num_worlds: int, device: str = "warp", nconmax: int = NCONMAX
    ) -> None:
        if device not in WARP_DEVICES:
            raise ConfigError(f"WarpWorlds device={device!r} is not one of {', '.join(WARP_DEVICES)}")
        mjw = _import_warp(device)
        import warp as wp

        if WARP_DEVICES[device] == "cuda" and not wp.get_cuda_device_count():
            raise ConfigError(f"device={device!r} needs a CUDA GPU (warp sees none): {GPU_HINT}, or use device='cpu'")
        self._wp, self._mjw = wp, mjw
        self.device = wp.get_device(WARP_DEVICES[device])
        self.num_worlds, self.model = num_worlds, model
        self.nconmax = nconmax
        try:
            adapted = warp_model(model)
            with wp.ScopedDevice(self.device):
                self.mw = mjw.put_model(adapted)
                # a vehicle set's tyres and actuator rate limits: Warp kernels as the model's callbacks
                self.tyres = WarpTyres(wp, self.mw, model, data, num_worlds) if needs_callbacks(model) else None
                # pyramidal cones: 2 (condim - 1) rows per contact; elliptic fewer
                njmax = nconmax * 2 * (int(model.geom_condim.max(initial=1)) - 1 or 1)
                self.dw = mjw.put_data(adapted, data, nworld=num_worlds, nconmax=nconmax, njmax=njmax)
                if self.device.is_cuda:  # a graph capture needs every kernel loaded: step a scratch copy once
                    mjw.step(self.mw, mjw.put_data(adapted, data, nworld=num_worlds, nconmax=nconmax, njmax=njmax))
                    if self.tyres is not None:  # that step copied the scratch worlds' wheel loads
                        self.tyres.reset(np.arange(num_worlds))
        except NotImplementedError as error:  # mujoco-warp names the unsupported feature
            raise ConfigError(f"MuJoCo Warp cannot run this model: {error}; use device='cpu'") from None
        self._graphs: dict[int, Any] = {}

    # --- host -> device ---------------------------------------------------------------------------
    def reset(
        self,
        qpos: np.ndarray,
        qvel: np.ndarray,
        worlds: np.ndarray | None = None,
        ctrl: np.ndarray | None = None,
        qacc_warmstart: np.ndarray | None = None,
        sensordata: np.ndarray | None = None,
    ) -> None:
        """Set the chosen worlds' state (default: all) from host arrays of one row per chosen world; their time
        and act go to zero, and ctrl and warm start too unless given. xpos and the contacts stay those of the
        last step until the next one. sensordata: the sensors of the step before (a tyre model's wheel loads for
        the next step; default: the initial state's)."""
        rows = np.arange(self.num_worlds) if worlds is None else np.asarray(worlds)
        if self.tyres is not None:
            self.tyres.reset(rows, sensordata)
        for field, value in (
            ("qpos", qpos),
            ("qvel", qvel),
            ("ctrl", ctrl),
            ("qacc_warmstart", qacc_warmstart),
            ("act", None),
            ("time", None),
        ):
            target = getattr(self.dw, field)
            if target.size:
                host = target.numpy()
                host[rows] = 0.0 if value is None else np.asarray(value).reshape(host[rows].shape)
                target.assign(host)

    def set_ctrl(self, ctrl: np.ndarray) -> None:
        """Every world's actuator controls, (N, nu)."""
        self.dw.ctrl.assign(np.asarray(ctrl, np.float32).reshape(self.num_worlds, self.model.nu))

    # --- stepping -----------------------------------------------------------------------------------
    def step(self, nsteps: int = 1) -> None:
        """Every world `nsteps` physics steps on (on CUDA: one graph per nsteps, captured on first use)."""
        wp, mjw = self._wp, self._mjw
        with wp.ScopedDevice(self.device):
            if not self.device.is_cuda:
                for _ in range(nsteps):
                    mjw.step(self.mw, self.dw)
            else:
                graph = self._graphs.get(nsteps)
                if graph is None:
                    with wp.ScopedCapture() as capture:
                        for _ in range(nsteps):
                            mjw.step(self.mw, self.dw)
                    graph = self._graphs[nsteps] = capture.graph
                wp.capture_launch(graph)
            wp.synchronize_device(self.device)

    # --- device -> host ---------------------------------------------------------------------------
    def qpos(self) -> np.ndarray:
        """(N, nq) float64."""
        return self.dw.qpos.numpy().astype(np.float64)

    def qvel(self) -> np.ndarray:
        """(N, nv) float64."""
        return self.dw.qvel.numpy().astype(np.float64)

    def qacc_warmstart(self) -> np.ndarray:
        """(N, nv) float64: the solver's warm start for the next step."""
        return self.dw.qacc_warmstart.numpy().astype(np.float64)

    def act(self) -> np.ndarray:
        """(N, na) float64: actuator activations."""
        return self.dw.act.numpy().astype(np.float64).reshape(self.num_worlds, self.model.na)

    def body_pose(self, body: int) -> tuple[np.ndarray, np.ndarray]:
        """A body's frame in every world after the last step: xpos (N, 3) and xmat (N, 3, 3), float64."""
        return (
            self.dw.xpos.numpy()[:, body].astype(np.float64),
            self.dw.xmat.numpy()[:, body].reshape(self.num_worlds, 3, 3).astype(np.float64),
        )

    def body_velocity(self, body: int) -> np.ndarray:
        """(N, 6) [angular, linear] velocity of a body's frame in that frame, after the last step: what
        mj_objectVelocity(mjOBJ_XBODY, flg_local=1) gives on CPU MuJoCo's data after mj_step (DriveBatch's speed
        is its [3])."""
        d = self.dw
        cvel = d.cvel.numpy()[:, body].astype(np.float64)  # at the subtree centre of mass of the body's root
        offset = d.xpos.numpy()[:, body] - d.subtree_com.numpy()[:, int(self.model.body_rootid[body])]
        angular, linear = cvel[:, :3], cvel[:, 3:] - np.cross(offset, cvel[:, :3])
        xmat = d.xmat.numpy()[:, body].reshape(self.num_worlds, 3, 3).astype(np.float64)
        return np.concatenate([np.einsum("nji,nj->ni", xmat, angular), np.einsum("nji,nj->ni", xmat, linear)], 1)

    def contacts(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The contacts of the last step over all worlds: world (K,), geom pair (K, 2), normal z (K,)."""
        c = self.dw.contact
        n = int(self.dw.nacon.numpy()[0])
        if n > self.dw.naconmax:
            raise ConfigError(
                f"MuJoCo Warp found {n} contacts, more than the {self.dw.naconmax} allocated: raise WarpWorlds nconmax"
            )
        return c.worldid.numpy()[:n], c.geom.numpy()[:n], c.frame.numpy()[:n, 0, 2].astype(np.float64)

    def crashed(self, kind: np.ndarray, support_normal_z: float) -> np.ndarray:
        """(N,) bool: whether each world's contacts hold a crash under a CrashTable's geom-pair `kind` table
        (1 crash, 2 crash unless the normal is upright: |normal z| > support_normal_z)."""
        world, geom, normal_z = self.contacts()
        pair = kind[geom[:, 0], geom[:, 1]]
        crash = (pair == 1) | ((pair == 2) & (np.abs(normal_z) <= support_normal_z))
        out = np.zeros(self.num_worlds, bool)
        out[world[crash]] = True
        return out


class WarpLidar:
    """One lidar's scans in every world of a WarpWorlds, cast by MuJoCo Warp on its device (`mujoco_warp.rays`, one
    thread block per (world, beam)): the rule of the CPU lidar's 3-D cast (sensors/raycast/mujoco3d.py MujocoRays).

    The worlds are posed at their current qpos (mujoco_warp.kinematics, as the CPU fallback's mj_kinematics), each
    world's ray origins and directions are formed on the device from the pose of the body the laser is welded to
    (`body`; `local_origin` (3,) and `local_axes` (3, 3) in its frame: sensors/laser_mount.py LaserMount) and the
    fan's fixed beam directions, and only geoms of `group` are seen. The car must not see itself: `rays` excludes one
    body per ray and the car is several, so the cast reads a copy of the device model whose `hidden_geoms` sit in
    another geom group (no physics reads geom_group; the stepped model is untouched). A hit nearer than range_min is
    looked past (a second cast from range_min on, only when a beam needs it) and one beyond range_max is inf.
    Distances come back as float64 from float32 casts (~1e-6 m off the CPU cast at the lidar's ranges).
    """

    def __init__(
        self,
        worlds: WarpWorlds,
        body: int,
        local_origin: np.ndarray,
        local_axes: np.ndarray,
        fan_directions: np.ndarray,
        range_min: float,
        range_max: float,
        group: int,
        hidden_geoms: np.ndarray,
    ) -> None:
        wp = worlds._wp
        self.worlds, self.body = worlds, body
        self.range_min, self.range_max = float(range_min), float(range_max)
        count = fan_directions.shape[1]
        local = (np.asarray(local_axes, np.float64)[:, :2] @ np.asarray(fan_directions, np.float64)).T  # (beams, 3)
        n = worlds.num_worlds
        mask = [0] * mujoco.mjNGROUP
        mask[group] = 1
        groups = worlds.model.geom_group.copy()
        groups[np.asarray(hidden_geoms, int)] = (group + 1) % mujoco.mjNGROUP
        with wp.ScopedDevice(worlds.device):
            self._model = copy.copy(worlds.mw)  # the stepped model's arrays, but its own geom groups
            self._model.geom_group = wp.array(groups.astype(np.int32), dtype=int)
            self._group = wp.types.vector(length=6, dtype=wp.float32)(*mask)  # mujoco_warp's vec6 (geomgroup)
            self._origin = wp.vec3(*np.asarray(local_origin, np.float64).tolist())
            self._local = wp.array(local.astype(np.float32), dtype=wp.vec3)
            self._exclude = wp.full(count, -1, dtype=int)
            self._pnt = wp.empty((n, count), dtype=wp.vec3)
            self._vec = wp.empty((n, count), dtype=wp.vec3)
            self._dist = wp.empty((n, count), dtype=float)
            self._geom = wp.empty((n, count), dtype=int)
            self._normal = wp.empty((n, count), dtype=wp.vec3)
        self._kernel = _beams_kernel(wp)

    def _cast(self, shift: float) -> np.ndarray:
        """(N, beams) float64 distances from the ray origins moved `shift` along each beam, -1 where none."""
        wp, mjw, worlds = self.worlds._wp, self.worlds._mjw, self.worlds
        with wp.ScopedDevice(worlds.device):
            wp.launch(
                self._kernel,
                dim=self._pnt.shape,
                inputs=[worlds.dw.xpos, worlds.dw.xmat, self.body, self._origin, self._local, float(shift)],
                outputs=[self._pnt, self._vec],
            )
            mjw.rays(
                self._model, worlds.dw, self._pnt, self._vec, self._group, True, self._exclude, self._dist,
                self._geom, self._normal,
            )  # fmt: skip
            wp.synchronize_device(worlds.device)
        return self._dist.numpy().astype(np.float64)

    def ranges(self) -> np.ndarray:
        """Noise-free ranges (N, beams) of every world at its current qpos, inf where nothing is within range."""
        wp, mjw, worlds = self.worlds._wp, self.worlds._mjw, self.worlds
        with wp.ScopedDevice(worlds.device):
            mjw.kinematics(worlds.mw, worlds.dw)
        dist = self._cast(0.0)
        dist[dist < 0.0] = np.inf
        near = dist < self.range_min
        if near.any():  # something before the ray start: look past it, as MujocoRays does
            past = self._cast(self.range_min)[near]
            dist[near] = np.where(past < 0.0, np.inf, self.range_min + past)
        dist[dist > self.range_max] = np.inf
        return dist


def _beams_kernel(wp: Any) -> Any:
    """The Warp kernel that forms every (world, beam)'s ray: origin body_pos + R (origin + shift d), direction R d,
    with R the body's rotation and d the beam's direction in the body frame."""

    @wp.kernel
    def beams(
        xpos: wp.array2d(dtype=wp.vec3),  # type: ignore[valid-type]
        xmat: wp.array2d(dtype=wp.mat33),  # type: ignore[valid-type]
        body: int,
        origin: wp.vec3,
        local: wp.array(dtype=wp.vec3),  # type: ignore[valid-type]
        shift: float,
        pnt: wp.array2d(dtype=wp.vec3),  # type: ignore[valid-type]
        vec: wp.array2d(dtype=wp.vec3),  # type: ignore[valid-type]
    ) -> None:
        world, beam = wp.tid()
        rotation = xmat[world, body]
        direction = rotation @ local[beam]
        pnt[world, beam] = xpos[world, body] + rotation @ origin + shift * direction
        vec[world, beam] = direction

    return beams


__all__ = ["NCONMAX", "WARP_DEVICES", "WarpLidar", "WarpWorlds", "warp_model"]
