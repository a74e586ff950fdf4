"""RL throughput: `python bench/bench_envs.py [--world walker] [--quick]`.

Env steps/s (20 Hz control, lidar on, random actions) for one DriveEnv, gym.make_vec with 4 envs (sync and async),
the native DriveBatch with 64 and 1024 worlds, and agent-steps/s of the PettingZoo race env with 4 cars. For the
batch, also bare MuJoCo on the same worlds and threads: mujoco.rollout stepping the same N states 20 physics steps
(one control period) per call, nothing else; the ratio batch / bare is the share of the time that is physics.
The same on one thread (a figure other load on the machine cannot skew), split into lidar and the rest, after it.
--quick: fewer steps and 256 instead of 1024 worlds (a CI-like run, well under a minute).
"""

from __future__ import annotations

import argparse
import os
import time

import gymnasium as gym
import mujoco
import mujoco.rollout
import numpy as np

import racecar_sim.envs  # noqa: F401  (registers the ids)
from machine_info import machine_line
from racecar_sim.envs import DRIVE_ID
from racecar_sim.envs.batch import DriveBatch


def rate(step, count: int, per_call: int) -> float:
    """Calls of `step` per second over `count` calls (after one warm-up call), times `per_call`."""
    step()
    start = time.perf_counter()
    for _ in range(count):
        step()
    return count * per_call / (time.perf_counter() - start)


def single(world: str, steps: int) -> float:
    env = gym.make(DRIVE_ID, world=world)
    env.reset(seed=0)
    actions = np.random.default_rng(0).uniform(-1, 1, (steps + 1, 2)).astype(np.float32)
    it = iter(actions)

    def step() -> None:
        *_, terminated, truncated, _ = env.step(next(it))
        if terminated or truncated:
            env.reset()

    result = rate(step, steps, 1)
    env.close()
    return result


def vector(world: str, mode: str, steps: int) -> float:
    envs = gym.make_vec(DRIVE_ID, num_envs=4, vectorization_mode=mode, world=world)
    envs.reset(seed=0)
    result = rate(lambda: envs.step(envs.action_space.sample()), steps, 4)
    envs.close()
    return result


def batch(world: str, worlds: int, steps: int, rounds: int = 3) -> tuple[float, float]:
    """(batch env steps/s, bare rollout world-control-steps/s) for `worlds` worlds on the same threads.

    The two are measured in alternating rounds and the best round of each kept, so that other load on the
    machine (a shared CI runner) hits both alike.
    """
    b = DriveBatch(worlds, world=world, seeds=0)
    b.reset()
    rng = np.random.default_rng(0)
    actions = rng.uniform(-1, 1, (worlds, 2)) * [0.5, 1.0]
    model, nstep = b.model, b.period_ns // b.step_ns
    spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
    state = np.empty((worlds, mujoco.mj_stateSize(model, spec)))
    ctrl = np.empty((worlds, nstep, model.nu))
    out = np.empty((worlds, nstep, state.shape[1]))
    sensors = np.empty((worlds, nstep, model.nsensordata))
    scratch = [mujoco.MjData(model) for _ in range(b.threads)]
    batch_rate = bare_rate = 0.0
    with mujoco.rollout.Rollout(nthread=b.threads if b.threads > 1 else 0) as pool:

        def bare() -> None:
            pool.rollout(model, scratch, state, ctrl, nstep=nstep, state=out, sensordata=sensors)
            state[:] = out[:, -1]

        for _ in range(rounds):
            batch_rate = max(batch_rate, rate(lambda: b.step(actions), steps, worlds))
            for i in range(worlds):  # the bare rollout goes on from the batch's worlds, same setpoints
                mujoco.mj_getState(model, b.world_data(i), state[i], spec)
            ctrl[:] = b.ctrl[:, None, :]
            bare_rate = max(bare_rate, rate(bare, steps, worlds))
    b.close()
    return batch_rate, bare_rate


def split(world: str, worlds: int, steps: int) -> tuple[float, float, float]:
    """One thread, microseconds per world and control step: (the batch's step, bare rollout of the same worlds,
    the batch's lidar alone on their poses). Not disturbed by other load on a second core."""
    b = DriveBatch(worlds, world=world, seeds=0, threads=1)
    b.reset()
    actions = np.random.default_rng(0).uniform(-1, 1, (worlds, 2)) * [0.5, 1.0]
    step = 1e6 / rate(lambda: b.step(actions), steps, worlds)
    model, nstep = b.model, b.period_ns // b.step_ns
    spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
    state = np.empty((worlds, mujoco.mj_stateSize(model, spec)))
    for i in range(worlds):
        mujoco.mj_getState(model, b.world_data(i), state[i], spec)
    ctrl = np.repeat(b.ctrl[:, None, :], nstep, axis=1)
    out = np.empty((worlds, nstep, state.shape[1]))
    with mujoco.rollout.Rollout(nthread=0) as pool:

        def bare() -> None:
            pool.rollout(model, mujoco.MjData(model), state, ctrl, nstep=nstep, state=out)
            state[:] = out[:, -1]

        physics_us = 1e6 / rate(bare, steps, worlds)
    lidar_us = 1e6 / rate(lambda: b.lidar.scans(b.qpos, b.seeds, b.time_ns), steps, worlds)
    b.close()
    return step, physics_us, lidar_us


def race(world: str, steps: int) -> float:
    from racecar_sim.envs import parallel_env

    env = parallel_env(num_cars=4, world=world)
    env.reset(seed=0)

    def step() -> None:
        if not env.agents:
            env.reset()
        env.step({a: env.action_space(a).sample() for a in env.agents})

    result = rate(step, steps, 4)
    env.close()
    return result


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--world", default="walker")
    parser.add_argument("--quick", action="store_true")
    args = parser.parse_args()
    print(machine_line(), flush=True)  # absolute figures belong to a machine
    steps = 20 if args.quick else 100
    print(f"world {args.world}, 20 Hz control, lidar on, {os.cpu_count()} CPU threads")
    print(f"{'DriveEnv x1':<28}{single(args.world, steps * 2):>12.0f} env steps/s")
    for mode in ("sync", "async"):
        print(f"{'make_vec x4 ' + mode:<28}{vector(args.world, mode, steps):>12.0f} env steps/s")
    for worlds in (64, 256 if args.quick else 1024):
        got, bare = batch(args.world, worlds, max(5, steps // (worlds // 64)))
        print(
            f"{f'DriveBatch x{worlds}':<28}{got:>12.0f} env steps/s   bare rollout {bare:>9.0f}/s   "
            f"ratio {got / bare:.2f}"
        )
    step, physics, lidar = split(args.world, 64, steps)
    print(
        f"{'DriveBatch x64, 1 thread':<28}{step:>9.0f} us per env step, bare rollout {physics:.0f} (ratio "
        f"{physics / step:.2f}); of the step: lidar {lidar:.0f}, the rest {step - physics - lidar:.0f}"
    )
    try:
        print(f"{'race x4 cars':<28}{race(args.world, steps):>12.0f} agent steps/s")
    except (ImportError, AttributeError) as exc:
        print(f"race env: not available ({exc})")


if __name__ == "__main__":
    main()
