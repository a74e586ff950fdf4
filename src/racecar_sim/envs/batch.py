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

Auto-reset: Gymnasium's SAME_STEP mode. A world whose episode ends (terminated: a crash; truncated:
max_episode_steps) is reset inside that step: the returned observation is the new episode's first, and
infos["final_obs"] / infos["final_info"] hold the last ones (with infos["_final_obs"] the mask of reset worlds).
A world's next seed is drawn from its own generator, as DriveEnv.reset() without a seed does.
"""

from __future__ import annotations

import os
import threading
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import TYPE_CHECKING, Any

import mujoco
import numpy as np
from gymnasium.utils import seeding

from racecar_sim.core.errors import ConfigError
from racecar_sim.core.rng import check_seed
from racecar_sim.core.time import ceil_to_step, to_ns
from racecar_sim.envs.agent import servo_geometry
from racecar_sim.envs.batch_command import BatchCommands
from racecar_sim.envs.batch_lidar import BatchLidar
from racecar_sim.envs.batch_reward import BatchProgress, CrashTable
from racecar_sim.envs.crash import CHECK_RATE, SUPPORT_NORMAL_Z
from racecar_sim.envs.drive import CONTROL_RATE, CRASH_PENALTY, NAVIGATION_TIMEOUT
from racecar_sim.envs.reward import world_centerline
from racecar_sim.envs.spaces import (
    SCAN,
    SPEED,
    STEERING,
    DriveLimits,
    action_space,
    check_action_mode,
    checked_action,
    observation_space,
    scan_observation,
    steering_from_hinges,
    to_command,
)
from racecar_sim.physics.builder import ROOT_JOINT
from racecar_sim.runtime.simulator import Simulator
from racecar_sim.worlds import load_world

if TYPE_CHECKING:  # mujoco-warp loads only for device="warp"
    from racecar_sim.envs.batch_warp import WarpWorlds

DEVICES = ("cpu", "warp", "warp-cpu")
MAX_EPISODE_STEPS = 1200
CHUNK_WORLDS = 64  # at most this many worlds per task of the thread pool
_STATE = mujoco.mjtState.mjSTATE_INTEGRATION
_EXTRA = mujoco.mjtState.mjSTATE_HISTORY | mujoco.mjtState.mjSTATE_PLUGIN | mujoco.mjtState.mjSTATE_PLASTIC


class DriveBatch:
    """N worlds of DriveEnv (same keywords), with numpy observations of leading axis N.

    seeds: one per world (or one int: world i gets seed + i); threads: worker threads (default: CPU count).
    device: "cpu", "warp" (MuJoCo Warp on a CUDA GPU: the `[gpu]` extra; see batch_warp.py) or "warp-cpu" (MuJoCo
    Warp on Warp's CPU device: slow, for tests). On Warp the physics is float32: the worlds agree with the CPU batch
    to ~1e-4 m, not bit for bit; lidar, noise and progress stay on the CPU.
    """

    def __init__(
        self,
        num_worlds: int,
        world: str | Path = "walker",
        seeds: int | list[int] | None = None,
        control_rate: float = CONTROL_RATE,
        lidar: bool = True,
        action: str = "normalized",
        max_speed: float | None = None,
        max_steering: float | None = None,
        crash_penalty: float = CRASH_PENALTY,
        centerline: str | Path | None = None,
        max_episode_steps: int | None = MAX_EPISODE_STEPS,
        profile: str = "seed",
        physics: str = "default",
        sensor_noise: bool = True,
        threads: int | None = None,
        device: str = "cpu",
    ) -> None:
        if device not in DEVICES:
            raise ConfigError(f"DriveBatch device={device!r} is not one of {', '.join(DEVICES)}")
        if not (isinstance(num_worlds, int) and num_worlds >= 1):
            raise ConfigError(f"DriveBatch num_worlds must be a whole number >= 1, got {num_worlds!r}")
        if not (isinstance(control_rate, (int, float)) and 1.0 / NAVIGATION_TIMEOUT < control_rate < float("inf")):
            raise ConfigError(
                f"DriveBatch control_rate {control_rate!r}: commands must come faster than "
                f"{1 / NAVIGATION_TIMEOUT:g} Hz (the navigation mux input's {NAVIGATION_TIMEOUT:g} s timeout)"
            )
        self.num_worlds, self.lidar_on = num_worlds, lidar
        self.action_mode = check_action_mode(action)
        self.limits = DriveLimits(max_speed or DriveLimits.max_speed, max_steering or DriveLimits.max_steering)
        self.crash_penalty, self.max_episode_steps = float(crash_penalty), max_episode_steps
        loaded = load_world(world)
        # near_walls off: every world steps the one model, so map walls cannot follow one world's car
        self.template = sim = Simulator(
            world=loaded,
            profile=profile,
            physics=physics,
            camera=False,
            lidar=lidar,
            sensor_noise=sensor_noise,
            near_walls=False,
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
        self.observation_space = observation_space(laser.spec) if laser is not None else None
        self.action_space = action_space(self.action_mode, self.limits)
        sim.reset(0)
        self._state0 = np.empty(mujoco.mj_stateSize(self.model, _STATE))
        mujoco.mj_getState(self.model, sim.data, self._state0, _STATE)
        n, nq, nv = num_worlds, self.model.nq, self.model.nv
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
        self._scratch = threading.local()
        self.qpos, self.qvel, self.speed = np.zeros((n, nq)), np.zeros((n, nv)), np.zeros(n)
        self.ctrl = np.zeros((n, self.model.nu))
        self.crashed = np.zeros(n, bool)
        self.time_ns = np.zeros(n, np.int64)
        self.steps = np.zeros(n, np.int64)
        self.seeds = np.zeros(n, np.int64)
        self.scan = np.zeros((n, laser.spec.samples if laser is not None else 0), np.float32)
        self._rngs: list[np.random.Generator] = [np.random.default_rng()] * n
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
        if device != "cpu":
            from racecar_sim.envs.batch_warp import WarpWorlds

            self.warp = WarpWorlds(self.model, self._rest, n, device=device)

    # --- the batch API ------------------------------------------------------------------------------
    def reset(self, seeds: int | list[int] | None = None) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
        """Every world to a new episode at the world's spawn pose; `seeds` (one per world, or one int: world i
        gets seed + i; default: those given to the constructor, else fresh entropy) seed each world as
        DriveEnv.reset(seed=...) does (the noise seed is the seed itself)."""
        seeds = self._seeds_arg if seeds is None else seeds
        n = self.num_worlds
        if seeds is None:
            seeds = [int(s) for s in np.random.SeedSequence().generate_state(n) % 2**31]
        elif isinstance(seeds, (int, np.integer)):
            seeds = [int(seeds) + i for i in range(n)]
        seeds = [check_seed(s) for s in seeds]
        if len(seeds) != n:
            raise ConfigError(f"DriveBatch.reset: {len(seeds)} seeds for {n} worlds")
        self._rngs = [seeding.np_random(s)[0] for s in seeds]
        worlds = np.arange(n)
        self._reset_worlds(worlds, np.array(seeds))
        self._observe(worlds)
        return self.observation(), {"seed": np.array(seeds)}

    def step(
        self, actions: np.ndarray
    ) -> tuple[dict[str, np.ndarray], np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        """Every world one control period with its action (N, 2); finished worlds are reset (SAME_STEP)."""
        actions = checked_action(
            actions,
            self.action_space,
            f"DriveBatch.step ({self.num_worlds} worlds)",
            (self.num_worlds, *self.action_space.shape),
        )
        command = to_command(actions, self.action_mode, self.limits)
        self.commands.ctrl(command[:, 0], command[:, 1], self.ctrl)
        self.steps += 1
        self._run()
        xy, yaw = self._planar_pose()
        progress = self.progress.step(xy, yaw)
        rewards = progress - np.where(self.crashed, self.crash_penalty, 0.0)
        terminated = self.crashed.copy()
        truncated = (self.steps >= self.max_episode_steps) if self.max_episode_steps else np.zeros_like(terminated)
        obs = self.observation()
        infos: dict[str, Any] = {"progress": progress, "crash": np.where(self.crashed, "wall", np.array(None))}
        done = terminated | truncated
        if done.any():
            worlds = np.flatnonzero(done)
            infos["final_obs"] = {k: v.copy() for k, v in obs.items()}
            infos["_final_obs"] = done
            seeds = np.array([int(self._rngs[i].integers(2**31)) for i in worlds.tolist()])
            self._reset_worlds(worlds, seeds)
            self._observe(worlds)
            obs = self.observation()
        return obs, rewards, terminated, truncated, infos

    def observation(self) -> dict[str, np.ndarray]:
        """The current observation of every world (new arrays)."""
        obs = {
            SPEED: self.speed.astype(np.float32)[:, None],
            STEERING: steering_from_hinges(
                self.qpos[:, self._hinge_qpos], self._hinge_points, self._wheelbase, self._servo
            ).astype(np.float32)[:, None],
        }
        if self.lidar is not None:
            obs = {SCAN: scan_observation(self.scan, self.range_max), **obs}
        return obs

    def close(self) -> None:
        """Stop the worker threads."""
        if self._pool is not None:
            self._pool.shutdown()
            self._pool = None

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
        return d

    def _reset_worlds(self, worlds: np.ndarray, seeds: np.ndarray) -> None:
        rest = self._rest
        self._mj_time[worlds], self.qpos[worlds], self.qvel[worlds] = rest.time, rest.qpos, rest.qvel
        self._act[worlds], self._warmstart[worlds], self.ctrl[worlds] = rest.act, rest.qacc_warmstart, rest.ctrl
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
            self._warmstart[i] = d.qacc_warmstart
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
        if self.lidar is not None:
            self.scan[:] = self.lidar.scans(self.qpos, self.seeds, self.time_ns)

    def _load(self, d: mujoco.MjData, i: int) -> None:
        """World i's state (and its ctrl) into d."""
        d.time, d.qpos[:], d.qvel[:], d.act[:] = self._mj_time[i], self.qpos[i], self.qvel[i], self._act[i]
        d.qacc_warmstart[:], d.ctrl[:] = self._warmstart[i], self.ctrl[i]
        if self._extra.shape[1]:
            mujoco.mj_setState(self.model, d, self._extra[i], _EXTRA)

    def _observe(self, worlds: np.ndarray) -> None:
        """Scans at the current pose of the chosen worlds, stamped with their time (a reset's first scan)."""
        if self.lidar is not None and len(worlds):
            self.scan[worlds] = self.lidar.scans(self.qpos[worlds], self.seeds[worlds], self.time_ns[worlds])

    def _planar_pose(self) -> tuple[np.ndarray, np.ndarray]:
        root = self.qpos[:, self.root_qpos : self.root_qpos + 7]
        w, x, y, z = root[:, 3:].T
        return root[:, :2].copy(), np.arctan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))


__all__ = ["DriveBatch"]
