"""DriveBatch: N independent copies of DriveEnv's world and car, stepped together (the native batched path).

One `step(actions)` call steps every world one control period. Per world it is what DriveEnv does, without the
node graph: the command path (the muxes forwarding the navigation command, servo_commands, the controllers'
clamps) is array code over the batch (batch_command.py), the physics runs in MuJoCo on a pool of threads (each
world's full integration state, warm start included, stepped with mj_step on its thread's MjData, the GIL
released), and the lidar is one batched 2-D cast (batch_lidar.py) with
each world's noise drawn as the single car draws it. For the same seeds and actions the state matches N
DriveEnvs / Simulators bit for bit (tests/test_envs_batch.py), and the observations to float32 rounding.

Why not mujoco.rollout: it takes a warm start in (initial_warmstart) but gives back only mjSTATE_FULLPHYSICS, which
holds no warm start (mjSTATE_WARMSTART), so a chain of rollouts (one per control step, or per crash-check interval)
cannot carry the solver's qacc_warmstart on and drifts from a continuously stepped car by ~1e-9 in qvel after 40
steps; nor does it give back the contact list the crash check reads at its instants. The bench
(bench/bench_envs.py) measures rollout as the bare physics rate to compare against.

The batch is a `gymnasium.vector.VectorEnv` (registered as the vector_entry_point of racecar_sim/Drive-v0:
`gym.make_vec("racecar_sim/Drive-v0", num_envs=N)` gives it): `num_envs`, `single_observation_space` and
`single_action_space` (DriveEnv's), `observation_space` / `action_space` batched with gymnasium's batch_space, the
reset(seed=..., options=...) and step(actions) of Gymnasium's vector API, and infos in its vector form (per key an
array over the worlds plus a "_key" mask of the worlds that have it). It behaves as
`gym.make_vec("racecar_sim/Drive-v0", num_envs=N, vectorization_mode="sync",
vector_kwargs={"autoreset_mode": AutoresetMode.SAME_STEP})` with the same seeds and actions: same spaces,
observations, rewards, flags and infos (tests/test_envs_vector.py).

Auto-reset: Gymnasium's SAME_STEP mode (metadata["autoreset_mode"]). A world whose episode ends (terminated: a
crash; truncated: max_episode_steps or time_limit) is reset inside that step: the step's observation for it is the
new episode's first, and its entries of the step's infos are its reset info ("progress" 0, "crash" None, "time" 0);
infos["final_obs"] (an object array: the last observation of each reset world, None for the others) and
infos["final_info"] (the last step's info, in the vector form) hold what ended, with the masks infos["_final_obs"] and
infos["_final_info"] of the reset worlds. The episode's last reward, terminated and truncated are the step's own. A
world's next seed is drawn from its own generator, as DriveEnv.reset() without a seed does. Learners that bootstrap
a truncated episode's value read it from final_obs; racecar_sim.envs.sb3 hands it to Stable-Baselines3 as its
"terminal_observation".
"""

from __future__ import annotations

import os
import threading
from collections.abc import Mapping, Sequence
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import TYPE_CHECKING, Any

import mujoco
import numpy as np
from gymnasium import spaces
from gymnasium.utils import seeding
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space

from racecar_sim.core.errors import ConfigError
from racecar_sim.core.rng import check_seed
from racecar_sim.core.throttle import is_finite_number
from racecar_sim.core.time import NS_PER_S, ceil_to_step, to_ns
from racecar_sim.description.vehicle_params import DEFAULT_VEHICLE, VehicleParams, load_vehicle
from racecar_sim.envs.agent import servo_geometry
from racecar_sim.envs.batch_command import BatchCommands
from racecar_sim.envs.batch_lidar import BatchLidar
from racecar_sim.envs.batch_reward import BatchProgress, CrashTable
from racecar_sim.envs.crash import CHECK_RATE, SUPPORT_NORMAL_Z
from racecar_sim.envs.drive import CONTROL_RATE, CRASH_PENALTY, NAVIGATION_TIMEOUT, spawn_pose
from racecar_sim.envs.reward import world_centerline
from racecar_sim.envs.spaces import (
    MAX_SPEED,
    MAX_STEERING,
    SCAN,
    SPEED,
    SPEED_BOUND,
    STEERING,
    DriveLimits,
    action_space,
    check_action_mode,
    checked_action,
    default_specs,
    observation_space,
    scan_observation,
    steering_from_hinges,
    to_command,
)
from racecar_sim.physics.builder import ROOT_JOINT
from racecar_sim.runtime.simulator import Simulator
from racecar_sim.worlds import Spawn, load_world

if TYPE_CHECKING:  # mujoco-warp loads only for device="warp"
    from racecar_sim.envs.batch_warp import WarpLidar, WarpWorlds
    from racecar_sim.sensors.lidar import LidarPublisher

DEVICES = ("cpu", "warp", "warp-cpu")
LIDAR_ON = ("host", "device")  # where a Warp batch casts its lidar
MAX_EPISODE_STEPS = 1200
CHUNK_WORLDS = 64  # at most this many worlds per task of the thread pool
_STATE = mujoco.mjtState.mjSTATE_INTEGRATION
_EXTRA = mujoco.mjtState.mjSTATE_HISTORY | mujoco.mjtState.mjSTATE_PLUGIN | mujoco.mjtState.mjSTATE_PLASTIC


class DriveBatch(VectorEnv[dict[str, np.ndarray], np.ndarray, np.ndarray]):
    """N worlds of DriveEnv (same keywords) as a Gymnasium VectorEnv: observations, rewards and flags with a leading
    axis of N, infos in Gymnasium's vector form, SAME_STEP autoreset (see the module's docstring).

    `gym.make_vec("racecar_sim/Drive-v0", num_envs=N)` (vectorization_mode "vector_entry_point", Gymnasium's default
    for an id that has one) builds it. num_envs: the number of worlds (`num_worlds=` is its old name).
    seeds: seed the first reset() that is given none (one per world, or one int: world i gets seed + i).
    threads: worker threads (default: CPU count). lidar=False drops the scan from the observation.
    max_episode_steps: the episode's step limit (truncated; default 1200, Drive-v0's), None for none.
    device: "cpu", "warp" (MuJoCo Warp on a CUDA GPU: the `[gpu]` extra; see batch_warp.py) or "warp-cpu" (MuJoCo
    Warp on Warp's CPU device: slow, for tests). On Warp the physics is float32: the worlds agree with the CPU batch
    to ~1e-4 m, not bit for bit; progress and the lidar's noise stay on the CPU (the lidar's casts too unless
    lidar_on="device").
    lidar_on: where a Warp batch casts the lidar: "host" (default: the CPU batch's casts at the worlds' qpos, copied
    back) or "device" (MuJoCo Warp's batched rays on the Warp device, float32: batch_warp.py WarpLidar; only the
    (N, beams) distances come back, the noise is drawn on the host as on the CPU).
    DriveEnv's camera and render_mode are taken and refused: the batch has no camera and renders nothing.
    """

    metadata: dict[str, Any] = {"autoreset_mode": AutoresetMode.SAME_STEP, "render_modes": []}

    def __init__(
        self,
        num_envs: int | None = None,
        world: str | Path = "walker",
        *,
        centerline: str | Path | None = None,
        control_rate: float = CONTROL_RATE,
        action: str = "normalized",
        max_speed: float | None = None,
        max_steering: float | None = None,
        crash_penalty: float = CRASH_PENALTY,
        time_limit: float | None = None,
        camera: bool = False,
        profile: str = "seed",
        physics: str = "default",
        sensor_noise: bool = True,
        render_mode: str | None = None,
        seeds: int | Sequence[int] | None = None,
        lidar: bool = True,
        max_episode_steps: int | None = MAX_EPISODE_STEPS,
        threads: int | None = None,
        device: str = "cpu",
        num_worlds: int | None = None,
        lidar_on: str = "host",
        vehicle: str | Path | VehicleParams = DEFAULT_VEHICLE,
    ) -> None:
        n = _world_count(num_envs, num_worlds)
        params = load_vehicle(vehicle)
        if device not in DEVICES:
            raise ConfigError(f"DriveBatch device={device!r} is not one of {', '.join(DEVICES)}")
        if lidar_on not in LIDAR_ON:
            raise ConfigError(f"DriveBatch lidar_on={lidar_on!r} is not one of {', '.join(LIDAR_ON)}")
        if lidar_on == "device" and device == "cpu":
            raise ConfigError(
                f"DriveBatch lidar_on='device' casts the lidar with MuJoCo Warp: it needs device='warp' or "
                f"'warp-cpu', got device={device!r}"
            )
        if not (isinstance(control_rate, (int, float)) and 1.0 / NAVIGATION_TIMEOUT < control_rate < float("inf")):
            raise ConfigError(
                f"DriveBatch control_rate {control_rate!r}: commands must come faster than "
                f"{1 / NAVIGATION_TIMEOUT:g} Hz (the navigation mux input's {NAVIGATION_TIMEOUT:g} s timeout)"
            )
        if camera:
            raise ConfigError(
                "DriveBatch has no camera: for camera observations vectorise DriveEnv, "
                'gym.make_vec("racecar_sim/DriveCamera-v0", num_envs=N, vectorization_mode="async")'
            )
        if render_mode is not None:
            raise ConfigError(
                f"DriveBatch renders nothing (render_mode={render_mode!r}): for frames vectorise DriveEnv, "
                'gym.make_vec("racecar_sim/Drive-v0", num_envs=N, vectorization_mode="sync", render_mode="rgb_array")'
            )
        if time_limit is not None and not (is_finite_number(time_limit) and time_limit > 0):
            raise ConfigError(f"DriveBatch time_limit must be a positive number of seconds, got {time_limit!r}")
        if max_episode_steps is not None and not (
            isinstance(max_episode_steps, (int, np.integer))
            and not isinstance(max_episode_steps, bool)
            and max_episode_steps >= 1
        ):
            raise ConfigError(
                f"DriveBatch max_episode_steps must be a whole number >= 1 or None, got {max_episode_steps!r}"
            )
        self.num_envs = self.num_worlds = n
        self.lidar_on = lidar
        self.action_mode = check_action_mode(action)
        self.limits = DriveLimits(
            MAX_SPEED if max_speed is None else max_speed, MAX_STEERING if max_steering is None else max_steering
        )
        self.crash_penalty, self.max_episode_steps = float(crash_penalty), max_episode_steps
        self.time_limit_ns = None if time_limit is None else to_ns(time_limit)
        self.render_mode = None
        loaded = load_world(world)
        self._world_key = str(world)
        # near_walls off: every world steps the one model, so map walls cannot follow one world's car
        self.template = sim = Simulator(
            world=loaded,
            profile=profile,
            physics=physics,
            camera=False,
            lidar=lidar,
            sensor_noise=sensor_noise,
            near_walls=False,
            vehicle=params,
        )
        self.model, car = sim.model, sim.car
        self.period_ns, self.step_ns = to_ns(1.0 / control_rate), sim.step_ns
        self.commands = BatchCommands(car)
        root_joint = self.model.joint(car.names.mj(ROOT_JOINT)).id
        self.root_qpos = int(self.model.jnt_qposadr[root_joint])
        self.root_body = car.state.body_id
        geometry = servo_geometry(car)
        front = [w for w in geometry.wheels if w.hinge_joint]
        self._hinge_qpos, _ = car.state.joint_indices([w.hinge_joint for w in front if w.hinge_joint])
        self._hinge_points = np.array([w.hinge_axis_point for w in front], np.float64)
        self._wheelbase, self._servo = geometry.wheelbase, car.profile.servo
        wheels = [self.model.body(car.names.mj(w.link)).id for w in geometry.wheels]
        self.crash_table = CrashTable(self.model, self.root_body, wheels)
        laser = None
        if lidar:
            assert car.lidar is not None, "the Simulator built with lidar=True has the car's lidar"
            laser = car.lidar
        self.lidar = BatchLidar(laser, self.model, self.root_body, self.root_qpos) if laser is not None else None
        self.range_max = laser.spec.range_max if laser is not None else 0.0
        single = observation_space(laser.spec) if laser is not None else motion_space()
        self.single_observation_space: spaces.Dict = single
        self.single_action_space: spaces.Box = action_space(self.action_mode, self.limits)
        self.observation_space = batch_space(self.single_observation_space, n)
        self.action_space = batch_space(self.single_action_space, n)
        sim.reset(0)
        self._state0 = np.empty(mujoco.mj_stateSize(self.model, _STATE))
        mujoco.mj_getState(self.model, sim.data, self._state0, _STATE)
        # the sensors of the last step are no part of MuJoCo's state, but a tyre model reads its wheel loads from them
        # (physics/tyre_callback.py): kept per world as the state is
        self._sensordata0 = sim.data.sensordata.copy()
        nq, nv = self.model.nq, self.model.nv
        # Each world's state is kept in arrays and stepped on its thread's one MjData (an MjData per world: twice the
        # memory at 1024 worlds, each one's working memory pulled through the cache). Only what mj_step changes is
        # per world: time, qpos, qvel, act, the warm start (and any history/plugin/plastic state); ctrl is set each
        # step, the rest (applied forces, mocap, eq_active, userdata) stays at the reset state. Copied as arrays, not
        # with mj_setState/mj_getState: those release the GIL, and each re-acquisition can wait on another thread.
        self._rest = self._fresh_data()
        self._extra0 = np.empty(mujoco.mj_stateSize(self.model, _EXTRA))
        mujoco.mj_getState(self.model, self._rest, self._extra0, _EXTRA)
        self._extra = np.zeros((n, len(self._extra0)))
        self._mj_time, self._act, self._warmstart = np.zeros(n), np.zeros((n, self.model.na)), np.zeros((n, nv))
        self._sensordata = np.tile(self._sensordata0, (n, 1))
        self._scratch = threading.local()
        self.qpos, self.qvel, self.speed = np.zeros((n, nq)), np.zeros((n, nv)), np.zeros(n)
        self.ctrl = np.zeros((n, self.model.nu))
        self.crashed = np.zeros(n, bool)
        self.time_ns = np.zeros(n, np.int64)
        self.steps = np.zeros(n, np.int64)
        self.seeds = np.zeros(n, np.int64)
        self.scan = np.zeros((n, laser.spec.samples if laser is not None else 0), np.float32)
        # each world's generator, as DriveEnv's np_random: seeded by a reset's seed, drawing the next episode's seed
        self._rngs: list[np.random.Generator | None] = [None] * n
        self.progress = BatchProgress(world_centerline(loaded, centerline), n)
        self.threads = threads or os.cpu_count() or 1
        self._pool = ThreadPoolExecutor(self.threads) if self.threads > 1 else None
        # several chunks per thread, so that one thread's numpy/Python work (lidar, noise, crash checks: partly
        # under the GIL) overlaps another's physics (mj_step runs without it); not many more, as each costs GIL
        # hand-overs and numpy calls (measured on 2 cores: chunks of 32-64 best, 4 a third slower)
        per_chunk = max(1, min(CHUNK_WORLDS, -(-n // self.threads)))
        self._chunks = [np.arange(k, min(k + per_chunk, n)) for k in range(0, n, per_chunk)]
        self._velocity = [np.zeros(6) for _ in range(n)]
        self._seeds_arg = seeds
        self.warp: WarpWorlds | None = None
        self.warp_lidar: WarpLidar | None = None
        if device != "cpu":
            from racecar_sim.envs.batch_warp import WarpWorlds

            self.warp = WarpWorlds(self.model, self._rest, n, device=device)
            if lidar_on == "device" and laser is not None:
                self.warp_lidar = self._device_lidar(laser)

    # --- the Gymnasium vector API -------------------------------------------------------------------
    def reset(
        self,
        *,
        seed: int | Sequence[int | None] | None = None,
        options: Mapping[str, Any] | None = None,
        seeds: int | Sequence[int | None] | None = None,
    ) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
        """Worlds to a new episode, as SyncVectorEnv resets N DriveEnvs: `seed` one int (world i gets seed + i) or
        one per world (None: that world draws one); without it a world's seed is drawn from its own generator (as
        DriveEnv.reset() without a seed), except that the first reset takes the constructor's `seeds` when given.
        A world's noise seed is its reset seed. `seeds=` is the old name of `seed`.

        options: "spawn" (a Spawn or (x, y, yaw): every world reset starts there, as DriveEnv's option), "reset_mask"
        (a bool array of N: reset only those worlds, Gymnasium's partial reset), "world" (only the batch's own: one
        batch steps one world's model). Infos: DriveEnv's reset info per world, in the vector form."""
        if seeds is not None:
            if seed is not None:
                raise ConfigError("DriveBatch.reset: give seed= (or seeds=, its old name), not both")
            seed = seeds
        n = self.num_envs
        options = dict(options or {})
        mask = self._reset_mask(options.get("reset_mask"))
        world = options.get("world")
        if world is not None and str(world) != self._world_key:
            raise ConfigError(
                f"DriveBatch.reset: options world={str(world)!r}: a batch steps one world ({self._world_key!r}); "
                "make a new DriveBatch(world=...) for another"
            )
        spawn = options.get("spawn")
        rest = self._spawn_data(spawn_pose(spawn)) if spawn is not None else self._rest
        if seed is None and self._seeds_arg is not None and all(rng is None for rng in self._rngs):
            seed = self._seeds_arg
        given: list[int | None]
        if seed is None:
            given = [None] * n
        elif isinstance(seed, (int, np.integer)):
            base = check_seed(seed)
            given = [base + i for i in range(n)]
        else:
            given = [None if s is None else check_seed(s) for s in seed]
            if len(given) != n:
                raise ConfigError(f"DriveBatch.reset: {len(given)} seeds for {n} worlds")
        if isinstance(seed, (int, np.integer)):
            super().reset(seed=int(seed))
        worlds = np.flatnonzero(mask)
        for i in worlds.tolist():
            if given[i] is not None:
                self._rngs[i] = seeding.np_random(given[i])[0]
        new_seeds = np.array([given[i] if given[i] is not None else self._next_seed(i) for i in worlds.tolist()])
        self._reset_worlds(worlds, new_seeds, rest)
        self._observe(worlds)
        return self.observation(), self._infos(mask, np.zeros(n), np.full(n, None, object))

    def step(
        self, actions: np.ndarray
    ) -> tuple[dict[str, np.ndarray], np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        """Every world one control period with its action (N, 2). A world whose episode ends is reset in the same
        step (SAME_STEP): its observation is the new episode's first, `infos["final_obs"][i]` / `infos["final_info"]`
        hold the last ones."""
        actions = checked_action(
            actions,
            self.single_action_space,
            f"DriveBatch.step ({self.num_envs} worlds)",
            (self.num_envs, *self.single_action_space.shape),
        )
        command = to_command(actions, self.action_mode, self.limits)
        self.commands.ctrl(command[:, 0], command[:, 1], self.ctrl)
        self.steps += 1
        self._run()
        xy, yaw = self._planar_pose()
        progress = self.progress.step(xy, yaw)
        terminated = self.crashed.copy()
        rewards = progress - np.where(terminated, self.crash_penalty, 0.0)
        truncated = np.zeros_like(terminated)
        if self.max_episode_steps is not None:
            truncated |= self.steps >= self.max_episode_steps
        if self.time_limit_ns is not None:
            truncated |= self.time_ns >= self.time_limit_ns
        obs = self.observation()
        crash = np.where(terminated, "wall", np.array(None)).astype(object)  # one car: what it hits is no car
        everyone = np.ones(self.num_envs, bool)
        infos = self._infos(everyone, progress, crash)
        done = terminated | truncated
        if done.any():
            worlds = np.flatnonzero(done)
            final_obs = np.full(self.num_envs, None, object)
            for i in worlds.tolist():
                final_obs[i] = {key: value[i].copy() for key, value in obs.items()}
            final_info = self._infos(done, progress, crash)
            seeds = np.array([self._next_seed(i) for i in worlds.tolist()])
            self._reset_worlds(worlds, seeds, self._rest)
            self._observe(worlds)
            obs = self.observation()
            # the reset worlds' own entries are their reset info, as SyncVectorEnv's SAME_STEP gives them
            infos["progress"][done], infos["crash"][done], infos["time"][done] = 0.0, None, 0.0
            infos.update(final_obs=final_obs, _final_obs=done.copy(), final_info=final_info, _final_info=done.copy())
        return obs, rewards, terminated, truncated, infos

    def observation(self) -> dict[str, np.ndarray]:
        """The current observation of every world (new arrays)."""
        obs = {
            SPEED: np.clip(self.speed, -SPEED_BOUND, SPEED_BOUND).astype(np.float32)[:, None],
            STEERING: steering_from_hinges(
                self.qpos[:, self._hinge_qpos], self._hinge_points, self._wheelbase, self._servo
            ).astype(np.float32)[:, None],
        }
        if self.lidar is not None:
            obs = {SCAN: scan_observation(self.scan, self.range_max), **obs}
        return obs

    def render(self) -> None:
        """Nothing: the batch has no render mode (vectorise DriveEnv for frames)."""
        return None

    def close_extras(self, **kwargs: Any) -> None:
        """Stop the worker threads (close() calls this once)."""
        if self._pool is not None:
            self._pool.shutdown()
            self._pool = None

    def __repr__(self) -> str:
        return f"DriveBatch({self._world_key}, num_envs={self.num_envs})"

    def world_data(self, world: int) -> mujoco.MjData:
        """A new MjData holding world `world`'s current state (what mj_step goes on from; no forward pass run)."""
        d = self._fresh_data()
        self._load(d, world)
        return d

    # --- internals ------------------------------------------------------------------------------------
    def _fresh_data(self) -> mujoco.MjData:
        """An MjData at the reset state (every world's state at the start of an episode)."""
        d = mujoco.MjData(self.model)
        mujoco.mj_setState(self.model, d, self._state0, _STATE)
        d.sensordata[:] = self._sensordata0
        return d

    def _reset_mask(self, value: object) -> np.ndarray:
        """options["reset_mask"] as a bool array of N (all worlds when not given); ConfigError for anything else."""
        n = self.num_envs
        if value is None:
            return np.ones(n, bool)
        if not (isinstance(value, np.ndarray) and value.dtype == np.bool_ and value.shape == (n,) and value.any()):
            raise ConfigError(
                f"DriveBatch.reset: options reset_mask must be a numpy bool array of shape ({n},) with a True, "
                f"got {value!r}"
            )
        return value

    def _spawn_data(self, pose: Spawn) -> mujoco.MjData:
        """An MjData at the reset state with the car at `pose` (checked as DriveEnv's spawn option is: a pose in a
        wall or off the ground is a WorldError, and nothing changes)."""
        sim = self.template
        sim.reset(0, pose)
        try:
            state = np.empty_like(self._state0)
            mujoco.mj_getState(self.model, sim.data, state, _STATE)
            sensordata = sim.data.sensordata.copy()
        finally:
            sim.reset(0)
        d = mujoco.MjData(self.model)
        mujoco.mj_setState(self.model, d, state, _STATE)
        d.sensordata[:] = sensordata
        return d

    def _next_seed(self, world: int) -> int:
        """World `world`'s next episode seed, from its generator (a fresh one if it was never seeded), as DriveEnv's
        reset without a seed draws it."""
        rng = self._rngs[world]
        if rng is None:
            rng = self._rngs[world] = seeding.np_random()[0]
        return int(rng.integers(2**31))

    def _infos(self, mask: np.ndarray, progress: np.ndarray, crash: np.ndarray) -> dict[str, Any]:
        """DriveEnv's info ("progress", "crash", "time") of the worlds in `mask`, in Gymnasium's vector form: an array
        per key (0.0 / None for the other worlds) and its "_key" mask."""
        values = {
            "progress": np.where(mask, progress, 0.0),
            "crash": np.where(mask, crash, np.array(None)).astype(object),
            "time": np.where(mask, self.time_ns / NS_PER_S, 0.0),
        }
        infos: dict[str, Any] = {}
        for key, value in values.items():
            infos[key], infos[f"_{key}"] = value, mask.copy()
        return infos

    def _reset_worlds(self, worlds: np.ndarray, seeds: np.ndarray, rest: mujoco.MjData) -> None:
        self._mj_time[worlds], self.qpos[worlds], self.qvel[worlds] = rest.time, rest.qpos, rest.qvel
        self._act[worlds], self._warmstart[worlds], self.ctrl[worlds] = rest.act, rest.qacc_warmstart, rest.ctrl
        self._sensordata[worlds] = rest.sensordata
        self._extra[worlds] = self._extra0
        self.seeds[worlds] = seeds
        self.time_ns[worlds] = 0
        self.steps[worlds] = 0
        self.crashed[worlds] = False
        self.speed[worlds] = 0.0  # mj_resetData + mj_forward: at rest
        if self.warp is not None:
            self.warp.reset(
                self.qpos[worlds],
                self.qvel[worlds],
                worlds,
                ctrl=self.ctrl[worlds],
                qacc_warmstart=self._warmstart[worlds],
                sensordata=self._sensordata[worlds],
            )
        xy, _ = self._planar_pose()
        self.progress.reset(worlds, xy[worlds])

    def _substeps(self, start: int, end: int) -> list[int]:
        """Physics steps between the crash checks (CHECK_RATE ticks since the episode start, and the end)."""
        tick = to_ns(1.0 / CHECK_RATE)
        times = sorted(
            {ceil_to_step(k * tick, self.step_ns) for k in range(start // tick + 1, end // tick + 1)} | {end}
        )
        times = [t for t in times if start < t <= end]
        return list(np.diff([start] + times) // self.step_ns)

    def _run(self) -> None:
        """Every world one control period on from its own episode time."""
        plans = {start: self._substeps(start, start + self.period_ns) for start in np.unique(self.time_ns).tolist()}
        if self.warp is not None:
            self._run_warp(self.warp, plans)
        elif self._pool is None:
            for chunk in self._chunks:
                self._run_chunk(chunk, plans)
        else:
            list(self._pool.map(lambda c: self._run_chunk(c, plans), self._chunks))

    def _run_chunk(self, chunk: np.ndarray, plans: dict[int, list[int]]) -> None:
        m, table, crashed, extra = self.model, self.crash_table, self.crashed, self._extra
        scratch = self._scratch
        if not hasattr(scratch, "data"):
            scratch.data = self._fresh_data()
        d = scratch.data
        for i in chunk.tolist():
            self._load(d, i)
            for n in plans[int(self.time_ns[i])]:
                mujoco.mj_step(m, d, nstep=n)
                if not crashed[i] and table.crashed(d):
                    crashed[i] = True
            self._mj_time[i], self.qpos[i], self.qvel[i], self._act[i] = d.time, d.qpos, d.qvel, d.act
            self._warmstart[i], self._sensordata[i] = d.qacc_warmstart, d.sensordata
            if extra.shape[1]:
                mujoco.mj_getState(m, d, extra[i], _EXTRA)
            # DriveEnv's speed: mj_objectVelocity on the data as mj_step leaves it
            mujoco.mj_objectVelocity(m, d, mujoco.mjtObj.mjOBJ_XBODY, self.root_body, self._velocity[i], 1)
            self.speed[i] = self._velocity[i][3]
        self.time_ns[chunk] += self.period_ns
        if self.lidar is not None:
            self.scan[chunk] = self.lidar.scans(self.qpos[chunk], self.seeds[chunk], self.time_ns[chunk])

    def _run_warp(self, warp: WarpWorlds, plans: dict[int, list[int]]) -> None:
        """Every world one control period on MuJoCo Warp. Worlds at different episode times check for crashes at
        different offsets into the period: the period is stepped in segments between the union of those offsets,
        and after each segment only the worlds whose own plan checks there are looked at."""
        crashed = self.crashed
        offsets = {start: set(np.cumsum(plan).tolist()) for start, plan in plans.items()}
        starts = self.time_ns.tolist()
        warp.set_ctrl(self.ctrl)
        done = 0
        for offset in sorted(set().union(*offsets.values())):
            warp.step(offset - done)
            done = offset
            checks_here = np.array([offset in offsets[start] for start in starts])
            crashed |= warp.crashed(self.crash_table.kind, SUPPORT_NORMAL_Z) & checks_here
        self.qpos[:], self.qvel[:] = warp.qpos(), warp.qvel()
        self._mj_time += done * self.model.opt.timestep
        self._warmstart[:], self._act[:] = warp.qacc_warmstart(), warp.act()
        self.speed[:] = warp.body_velocity(self.root_body)[:, 3]
        self.time_ns += self.period_ns
        lidar = self.lidar
        if lidar is not None and self.warp_lidar is not None:
            self.scan[:] = lidar.publish(self.warp_lidar.ranges(), self.seeds, self.time_ns)
        elif lidar is not None:  # on the host, chunk by chunk over the pool (the compiled casts release the GIL)

            def scan(chunk: np.ndarray) -> None:
                self.scan[chunk] = lidar.scans(self.qpos[chunk], self.seeds[chunk], self.time_ns[chunk])

            if self._pool is None:
                for chunk in self._chunks:
                    scan(chunk)
            else:
                list(self._pool.map(scan, self._chunks))

    def _device_lidar(self, laser: LidarPublisher) -> WarpLidar:
        """The car's lidar cast by MuJoCo Warp (lidar_on="device"): the host lidar's mount, fan, range limits, group
        and own geoms hidden, on the worlds' device."""
        from racecar_sim.envs.batch_warp import WarpLidar

        assert self.warp is not None and self.lidar is not None
        rays = laser.caster.rays3d
        if rays.walls is not None:  # never in a batch (built without near_walls): boxes no Warp model holds
            raise ConfigError(
                f"DriveBatch lidar_on='device': world {self._world_key!r} holds its map walls outside the MuJoCo "
                "model (near_walls), which MuJoCo Warp cannot cast; use lidar_on='host'"
            )
        mount, fan = self.lidar.mount, self.lidar.fan
        return WarpLidar(
            self.warp, self.root_body, mount.local_origin, mount.local_axes, fan.directions, fan.range_min,
            fan.range_max, rays.group, rays.hidden,
        )  # fmt: skip

    def _load(self, d: mujoco.MjData, i: int) -> None:
        """World i's state (and its ctrl) into d."""
        d.time, d.qpos[:], d.qvel[:], d.act[:] = self._mj_time[i], self.qpos[i], self.qvel[i], self._act[i]
        d.qacc_warmstart[:], d.ctrl[:], d.sensordata[:] = self._warmstart[i], self.ctrl[i], self._sensordata[i]
        if self._extra.shape[1]:
            mujoco.mj_setState(self.model, d, self._extra[i], _EXTRA)

    def _observe(self, worlds: np.ndarray) -> None:
        """Scans at the current pose of the chosen worlds, stamped with their time (a reset's first scan)."""
        if self.lidar is not None and self.warp_lidar is not None and len(worlds):  # every world is cast: keep these
            ranges = self.warp_lidar.ranges()[worlds]
            self.scan[worlds] = self.lidar.publish(ranges, self.seeds[worlds], self.time_ns[worlds])
        elif self.lidar is not None and len(worlds):
            self.scan[worlds] = self.lidar.scans(self.qpos[worlds], self.seeds[worlds], self.time_ns[worlds])

    def _planar_pose(self) -> tuple[np.ndarray, np.ndarray]:
        root = self.qpos[:, self.root_qpos : self.root_qpos + 7]
        w, x, y, z = root[:, 3:].T
        return root[:, :2].copy(), np.arctan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))


def _world_count(num_envs: object, num_worlds: object) -> int:
    """The number of worlds from num_envs or its old name num_worlds; ConfigError unless one whole number >= 1."""
    if num_envs is not None and num_worlds is not None and num_envs != num_worlds:
        raise ConfigError(f"DriveBatch: num_envs={num_envs!r} and num_worlds={num_worlds!r} differ: give one")
    n = num_envs if num_envs is not None else num_worlds
    if not (isinstance(n, (int, np.integer)) and not isinstance(n, bool) and n >= 1):
        raise ConfigError(f"DriveBatch num_envs (the number of worlds) must be a whole number >= 1, got {n!r}")
    return int(n)


def motion_space() -> spaces.Dict:
    """The observation of a batch without the lidar: speed and steering, as in observation_space()."""
    full = observation_space(default_specs()[0])
    return spaces.Dict({SPEED: full[SPEED], STEERING: full[STEERING]})


__all__ = ["DriveBatch"]
