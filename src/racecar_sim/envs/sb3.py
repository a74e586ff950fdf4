"""Stable-Baselines3 on the driving envs: a Gymnasium vector env (the native DriveBatch above all) as an SB3 VecEnv.

Imported only here, and only where Stable-Baselines3 is installed (the `[rl]` extra):

    from racecar_sim.envs.batch import DriveBatch
    from racecar_sim.envs.sb3 import SB3VecEnv
    from stable_baselines3 import PPO

    venv = SB3VecEnv(DriveBatch(16, world="walker", time_limit=30.0))
    PPO("MultiInputPolicy", venv).learn(100_000)

SB3VecEnv translates Gymnasium's vector API into SB3's: reset() gives the batched observation (a dict of arrays
for the Dict observation), step() (step_async + step_wait) gives (obs, rewards, dones, infos) with dones =
terminated | truncated and one info dict per world. The env must autoreset in the same step (SAME_STEP, as
DriveBatch does): a world that ended then has in its info the last step's info, "terminal_observation" (its last
observation, from infos["final_obs"]) and "TimeLimit.truncated" (truncated and not terminated), exactly as SB3's
DummyVecEnv gives them; its reset info goes to `reset_infos`. Seeds and options set through SB3's seed() and
set_options() go to the next reset. PooledLidar is an SB3 wrapper that gives the policy the pooled lidar features
(spaces.pooled_features) instead of the full scan.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any, cast

import gymnasium as gym
import numpy as np
from gymnasium.vector import AutoresetMode, VectorEnv
from stable_baselines3.common.vec_env import VecEnv, VecEnvWrapper
from stable_baselines3.common.vec_env.base_vec_env import VecEnvIndices, VecEnvObs, VecEnvStepReturn

from racecar_sim.core.errors import ConfigError
from racecar_sim.envs.spaces import SCAN, DriveLimits, pooled_features, pooled_space

MASKED = "_"  # Gymnasium's vector infos: "_key" is the mask of the worlds that have "key"


class SB3VecEnv(VecEnv):
    """A Gymnasium VectorEnv with SAME_STEP autoreset (DriveBatch) as a Stable-Baselines3 VecEnv."""

    def __init__(self, env: VectorEnv) -> None:
        mode = env.metadata.get("autoreset_mode")
        if mode != AutoresetMode.SAME_STEP:
            raise ConfigError(
                f"SB3VecEnv takes a vector env that resets in the same step (AutoresetMode.SAME_STEP, as DriveBatch); "
                f"{env} has autoreset_mode {mode}"
            )
        self.env = env
        self._actions: np.ndarray | None = None
        super().__init__(env.num_envs, env.single_observation_space, env.single_action_space)

    # --- SB3's VecEnv API ---------------------------------------------------------------------------
    def reset(self) -> VecEnvObs:
        """Every world to a new episode (with the seeds and options given since the last reset)."""
        seeds = list(self._seeds)
        seed: list[int | None] | None = None if all(s is None for s in seeds) else seeds
        options = [dict(o) for o in self._options]
        if any(o != options[0] for o in options):
            raise ConfigError("SB3VecEnv.reset: the worlds of one vector env take one set of reset options")
        # a seed per world: Gymnasium's SyncVectorEnv and DriveBatch take a list (VectorEnv's signature says int)
        obs, infos = self.env.reset(seed=cast(Any, seed), options=options[0] or None)
        self.reset_infos = [_world_info(infos, i) for i in range(self.num_envs)]
        self._reset_seeds()
        self._reset_options()
        return obs

    def step_async(self, actions: np.ndarray) -> None:
        self._actions = actions

    def step_wait(self) -> VecEnvStepReturn:
        assert self._actions is not None, "step_async() comes first"
        obs, rewards, terminated, truncated, infos = self.env.step(self._actions)
        self._actions = None
        dones = np.logical_or(terminated, truncated)
        final = infos.get("_final_obs", np.zeros(self.num_envs, bool))
        step_infos: list[dict[str, Any]] = []
        for i in range(self.num_envs):
            if final[i]:
                info = _world_info(infos["final_info"], i)
                info["terminal_observation"] = infos["final_obs"][i]
                self.reset_infos[i] = _world_info(infos, i)
            else:
                info = _world_info(infos, i)
            info["TimeLimit.truncated"] = bool(truncated[i] and not terminated[i])
            step_infos.append(info)
        return obs, np.asarray(rewards, np.float32), dones, step_infos

    def close(self) -> None:
        self.env.close()

    def get_images(self) -> Sequence[np.ndarray | None]:
        return [None] * self.num_envs  # the batch renders nothing

    def get_attr(self, attr_name: str, indices: VecEnvIndices = None) -> list[Any]:
        """The vector env's attribute, once per world asked for (the worlds share it)."""
        return [getattr(self.env, attr_name)] * len(list(self._get_indices(indices)))

    def set_attr(self, attr_name: str, value: Any, indices: VecEnvIndices = None) -> None:
        """Set an attribute of the vector env (shared by every world: only all of them at once)."""
        if len(list(self._get_indices(indices))) != self.num_envs:
            raise ConfigError(f"SB3VecEnv.set_attr({attr_name!r}): the worlds share the vector env's attributes")
        setattr(self.env, attr_name, value)

    def env_method(
        self, method_name: str, *method_args: Any, indices: VecEnvIndices = None, **method_kwargs: Any
    ) -> list[Any]:
        """Call a method of the vector env once; its result is given for each world asked for."""
        result = getattr(self.env, method_name)(*method_args, **method_kwargs)
        return [result] * len(list(self._get_indices(indices)))

    def env_is_wrapped(self, wrapper_class: type[gym.Wrapper], indices: VecEnvIndices = None) -> list[bool]:
        return [False] * len(list(self._get_indices(indices)))  # the worlds are no gym.Env: nothing wraps them


class PooledLidar(VecEnvWrapper):
    """The policy sees spaces.pooled_features (the scan min-pooled into `sectors`, speed and steering scaled) instead of
    the full observation; terminal observations are pooled alike."""

    def __init__(self, venv: VecEnv, sectors: int, limits: DriveLimits = DriveLimits()) -> None:
        space = venv.observation_space
        if not (isinstance(space, gym.spaces.Dict) and isinstance(space.spaces.get(SCAN), gym.spaces.Box)):
            raise ConfigError(f"PooledLidar pools the scan of a Dict observation; {venv} observes {space}")
        scan = space.spaces[SCAN]
        assert isinstance(scan, gym.spaces.Box)
        self.sectors, self.limits, self.range_max = sectors, limits, float(np.max(scan.high))
        super().__init__(venv, observation_space=pooled_space(sectors))

    def features(self, observation: Any) -> np.ndarray:
        return pooled_features(observation, self.sectors, self.range_max, self.limits)

    def reset(self) -> VecEnvObs:
        return self.features(self.venv.reset())

    def step_wait(self) -> VecEnvStepReturn:
        obs, rewards, dones, infos = self.venv.step_wait()
        for info in infos:
            if "terminal_observation" in info:
                info["terminal_observation"] = self.features(info["terminal_observation"])
        return self.features(obs), rewards, dones, infos


def _world_info(infos: dict[str, Any], i: int) -> dict[str, Any]:
    """World i's info from Gymnasium's vector infos (the keys whose mask holds i; nested dicts alike)."""
    info: dict[str, Any] = {}
    for key, value in infos.items():
        if key.startswith(MASKED) or key in ("final_obs", "final_info"):
            continue
        mask = infos.get(MASKED + key)
        if mask is not None and not mask[i]:
            continue
        info[key] = _world_info(value, i) if isinstance(value, dict) else value[i]
    return info


__all__ = ["PooledLidar", "SB3VecEnv"]
