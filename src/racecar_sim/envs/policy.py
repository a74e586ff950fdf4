"""A trained policy as a driver: a node that drives a car of any Simulator (`racecar-sim play`, a user's script) by a
policy, seeing and acting exactly as DriveEnv's agent does.

Every control period (DriveEnv's 20 Hz by default, from t = 0) the node takes the car's observation as DriveEnv
builds it (envs/agent.py: the latest scan, the forward speed, the measured steering), asks the policy for an
action and publishes it as DriveEnv's step does (spaces.to_command: an AckermannDriveStamped on the car's navigation
mux input). For the same seed, world and policy the car drives as DriveEnv stepped with that policy
(tests/test_play.py).

sb3_policy() turns a Stable-Baselines3 model (duck-typed: predict(), observation_space, action_space; nothing of SB3
is imported here) into the policy function and the action mode it was trained with, read from its saved spaces:
an observation Dict of DriveEnv's keys is given as is; a Box of sectors + 2 is spaces.pooled_features (what
examples/train_ppo.py trains on); an action Box of +-1 is "normalized", another Box(2) "raw" with its bounds as the
limits.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, cast

import numpy as np
from gymnasium import spaces

from racecar_sim.core.errors import ConfigError
from racecar_sim.core.time import to_ns
from racecar_sim.envs.agent import CarAgent
from racecar_sim.envs.drive import CONTROL_RATE, NAVIGATION_TIMEOUT
from racecar_sim.envs.spaces import SCAN, DriveLimits, checked_action, pooled_features
from racecar_sim.nodes import NodeBase, NodeContext
from racecar_sim.runtime.car import Car
from racecar_sim.runtime.simulator import Simulator

Observation = dict[str, np.ndarray]
Policy = Callable[[Observation], np.ndarray]  # DriveEnv's observation -> an action of the action space


class PolicyDriver(NodeBase):
    """Drives its car by `policy` at `rate` Hz through `agent` (the car's CarAgent: DriveEnv's observation and
    command). Build it with sim.add_node (attach_policy does)."""

    def __init__(self, ctx: NodeContext, agent: CarAgent, policy: Policy, rate: float = CONTROL_RATE) -> None:
        self.agent, self.policy = agent, policy
        self.actions = 0  # actions published
        self.timers = ctx.timers
        ctx.timers.every(rate, self._tick, "policy driver")  # at k / rate s, k = 1, 2, ...
        ctx.timers.at(ctx.now(), self._start, "policy driver start")  # when the run starts: a recording sees it

    def _tick(self, now_ns: int) -> None:
        self.agent.after_step()
        self._act()

    def _act(self) -> None:
        action = self.policy(self.agent.observation())
        self.agent.send(checked_action(action, self.agent.action_space, "the policy's action"))
        self.actions += 1

    def _start(self, now_ns: int) -> None:
        """The first action (at t = 0, when the sim runs), on a fresh scan, as DriveEnv's first step after its reset."""
        self.agent.fresh_sensors()
        self._act()

    def reset(self, seed: int) -> None:
        self.timers.at(0, self._start, "policy driver start")  # sim time is back at 0; its one-shots were dropped


def attach_policy(
    sim: Simulator,
    car: Car,
    policy: Policy,
    action: str = "normalized",
    limits: DriveLimits = DriveLimits(),
    rate: float = CONTROL_RATE,
) -> PolicyDriver:
    """A PolicyDriver on `car` (its own topics in a fleet); ConfigError for a car without a lidar or a rate the
    navigation mux's timeout or the physics cannot keep."""
    if car.lidar is None:
        raise ConfigError(f"the policy observes the lidar, and {car.model_name} has none: build it with lidar=True")
    top = 1.0 / sim.model.opt.timestep
    if not (1.0 / NAVIGATION_TIMEOUT < rate <= top):
        raise ConfigError(
            f"policy rate {rate:g} Hz: commands must come faster than {1 / NAVIGATION_TIMEOUT:g} Hz (the navigation "
            f"mux input's timeout) and at most at the physics rate ({top:g} Hz)"
        )
    agent = CarAgent(sim, car, action, limits, False, None, to_ns(1.0 / rate))
    return cast(PolicyDriver, sim.add_node(lambda ctx: PolicyDriver(ctx, agent, policy, rate), car=car))


def sb3_policy(model: Any, range_max: float, beams: int, deterministic: bool = True) -> tuple[Policy, str, DriveLimits]:
    """(policy, action mode, limits) of a Stable-Baselines3 model trained on DriveEnv's observation or on
    spaces.pooled_features of it (for a lidar of `beams` beams up to `range_max` m). ConfigError for other spaces."""
    action_space = model.action_space
    if not (isinstance(action_space, spaces.Box) and action_space.shape == (2,)):
        raise ConfigError(f"the policy's action space {action_space} is not DriveEnv's Box of (speed, steering)")
    if np.allclose(action_space.low, -1.0) and np.allclose(action_space.high, 1.0):
        mode, limits = "normalized", DriveLimits()
    else:
        mode, limits = "raw", DriveLimits(float(action_space.high[0]), float(action_space.high[1]))
    space = model.observation_space
    convert: Callable[[Observation], Any]
    if isinstance(space, spaces.Dict) and SCAN in space.spaces:
        keys = list(space.spaces)
        scan_shape = space.spaces[SCAN].shape
        if scan_shape != (beams,):
            raise ConfigError(f"the policy sees a scan of shape {scan_shape}; this car's lidar has {beams} beams")

        def convert(obs: Observation) -> Any:
            missing = [key for key in keys if key not in obs]
            if missing:
                raise ConfigError(f"the policy observes {', '.join(missing)}, which DriveEnv's agent does not give")
            return {key: obs[key] for key in keys}

    elif isinstance(space, spaces.Box) and len(space.shape) == 1 and 3 <= space.shape[0] <= beams + 2:
        sectors = space.shape[0] - 2

        def convert(obs: Observation) -> Any:
            return pooled_features(obs, sectors, range_max, limits)

    else:
        raise ConfigError(
            f"the policy's observation space {space} is neither DriveEnv's Dict (scan, speed, steering) nor the pooled "
            "lidar features of examples/train_ppo.py (a Box of sectors + 2)"
        )

    def policy(obs: Observation) -> np.ndarray:
        action, _ = model.predict(convert(obs), deterministic=deterministic)
        return np.asarray(action)

    return policy, mode, limits


__all__ = ["Policy", "PolicyDriver", "attach_policy", "sb3_policy"]
