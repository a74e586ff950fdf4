"""RaceEnv: N RACECARs racing in one world as a PettingZoo ParallelEnv (agents "car1", "car2", ...).

Each agent is one Car of a fleet Simulator: its own /<car>/scan (which sees the other cars), its command on
/<car>/vesc/ackermann_cmd_mux/input/navigation, its own progress reward and crash penalty (spaces and rewards as
DriveEnv's, see racecar_sim.envs). A car that touches a wall or an obstacle is terminated. Car-car contacts:
collision="involved" terminates the cars that touched, "all" every car, "none" nobody. A terminated car gets no
more commands: its mux times out and the default zero command stops it where it is, an obstacle for the others.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any, ClassVar

import numpy as np
from gymnasium import spaces
from pettingzoo import ParallelEnv

from racecar_sim.core.errors import ConfigError
from racecar_sim.core.rng import check_seed
from racecar_sim.core.time import NS_PER_S, to_ns
from racecar_sim.description.vehicle_params import DEFAULT_VEHICLE, VehicleParams
from racecar_sim.envs.agent import CarAgent, servo_geometry
from racecar_sim.envs.crash import CHECK_RATE, CrashMonitor
from racecar_sim.envs.drive import (
    CONTROL_RATE,
    CRASH_PENALTY,
    NAVIGATION_TIMEOUT,
    spawn_pose,
)
from racecar_sim.envs.reward import world_centerline
from racecar_sim.envs.spaces import (
    MAX_SPEED,
    MAX_STEERING,
    DriveLimits,
    check_action_mode,
    checked_action,
)
from racecar_sim.envs.view import EnvView
from racecar_sim.runtime.car import Car
from racecar_sim.runtime.simulator import Simulator
from racecar_sim.worlds import CAR_SPACING, Spawn, load_world, starting_row

COLLISION_MODES = ("involved", "all", "none")
MAX_CYCLES = 1200  # control steps before every agent is truncated (60 s at 20 Hz)


class RaceEnv(ParallelEnv):
    """N cars in `world`. num_cars: how many (2 by default); spawns: their poses (default: the world's starting row,
    worlds.starting_row: car_spacing m apart, back along the spawn heading or round a track's centerline).
    collision: "involved" | "all" | "none" (see the module doc). max_cycles: steps before truncation.
    The other keywords as DriveEnv's (world, centerline, control_rate, action, max_speed, max_steering,
    crash_penalty, camera, profile, physics, sensor_noise, render_mode)."""

    metadata: ClassVar[dict[str, Any]] = {
        "name": "racecar_race_v0",
        "render_modes": ["rgb_array", "human"],
        "render_fps": CONTROL_RATE,
        "is_parallelizable": True,
    }

    def __init__(
        self,
        num_cars: int = 2,
        world: str | Path = "walker",
        spawns: Sequence[Spawn] | None = None,
        collision: str = "involved",
        centerline: str | Path | None = None,
        control_rate: float = CONTROL_RATE,
        action: str = "normalized",
        max_speed: float | None = None,
        max_steering: float | None = None,
        crash_penalty: float = CRASH_PENALTY,
        max_cycles: int = MAX_CYCLES,
        camera: bool = False,
        profile: str = "seed",
        physics: str = "default",
        sensor_noise: bool = True,
        car_spacing: float = CAR_SPACING,
        render_mode: str | None = None,
        vehicle: str | Path | VehicleParams = DEFAULT_VEHICLE,
    ) -> None:
        if isinstance(num_cars, bool) or not isinstance(num_cars, int) or num_cars < 1:
            raise ConfigError(f"race env num_cars must be a whole number >= 1, got {num_cars!r}")
        if collision not in COLLISION_MODES:
            raise ConfigError(f"race env collision={collision!r} is not one of {', '.join(COLLISION_MODES)}")
        if not (isinstance(control_rate, (int, float)) and 1.0 / NAVIGATION_TIMEOUT < control_rate < float("inf")):
            raise ConfigError(
                f"race env control_rate must be above {1 / NAVIGATION_TIMEOUT:g} Hz (the navigation mux "
                f"input's timeout), got {control_rate!r}"
            )
        if render_mode not in (None, *self.metadata["render_modes"]):
            raise ConfigError(
                f"race env render_mode={render_mode!r} is not one of {', '.join(self.metadata['render_modes'])}"
            )
        self.collision, self.render_mode, self.max_cycles = collision, render_mode, int(max_cycles)
        self.crash_penalty = float(crash_penalty)
        self.period_ns = to_ns(1.0 / control_rate)
        limits = DriveLimits(
            MAX_SPEED if max_speed is None else max_speed, MAX_STEERING if max_steering is None else max_steering
        )
        loaded = load_world(world)
        if spawns is None:
            spawns = starting_row(loaded, num_cars, car_spacing)
        if len(spawns) != num_cars:
            raise ConfigError(f"race env spawns: {len(spawns)} poses for {num_cars} cars")
        self.possible_agents = [f"car{i + 1}" for i in range(num_cars)]
        cars = [
            Car(
                name,
                profile=profile,
                spawn=spawn_pose(s, what=f"race env spawns[{i}]"),
                camera=camera,
                vehicle=vehicle,
            )
            for i, (name, s) in enumerate(zip(self.possible_agents, spawns))
        ]
        self.sim = sim = Simulator(world=loaded, physics=physics, sensor_noise=sensor_noise, cars=cars)
        line = world_centerline(loaded, centerline)
        mode = check_action_mode(action)
        self._agents = {
            name: CarAgent(sim, car, mode, limits, camera, line, self.period_ns)
            for name, car in zip(self.possible_agents, sim.cars)
        }
        self.observation_spaces = {name: a.observation_space for name, a in self._agents.items()}
        self.action_spaces = {name: a.action_space for name, a in self._agents.items()}
        self.crashes = CrashMonitor.for_cars(sim.model, [(c.names, c.robot.root, servo_geometry(c)) for c in sim.cars])
        sim.scheduler.every(CHECK_RATE, lambda now: self.crashes.check(sim.data, now), "env crash check")
        self.agents: list[str] = []
        self._steps = 0
        self._rng = np.random.default_rng()
        self._view = EnvView(render_mode, sim)  # RenderingError (one line) where there is no GL

    def observation_space(self, agent: str) -> spaces.Dict:
        return self.observation_spaces[agent]

    def action_space(self, agent: str) -> spaces.Box:
        return self.action_spaces[agent]

    def reset(
        self, seed: int | None = None, options: Mapping[str, Any] | None = None
    ) -> tuple[dict[str, dict[str, np.ndarray]], dict[str, dict[str, Any]]]:
        """Every car back at its start (or options["spawn"]: a pose per car, or a mapping of agent names to poses,
        each a Spawn or (x, y, yaw); other keys are ignored), sensor noise from `seed` (drawn from the env's
        generator if None)."""
        if seed is not None:
            self._rng = np.random.default_rng(check_seed(seed))
        options = dict(options or {})
        spawn = options.get("spawn")
        if isinstance(spawn, Mapping):
            spawn = {name: spawn_pose(pose, what=f"reset options spawn[{name!r}]") for name, pose in spawn.items()}
        elif spawn is not None:
            try:
                poses = list(spawn)
            except TypeError:
                raise ConfigError(
                    f"reset options spawn={spawn!r}: give a pose per car, or a mapping of agent names to poses"
                ) from None
            spawn = [spawn_pose(pose, what=f"reset options spawn[{i}]") for i, pose in enumerate(poses)]
        self.sim.reset(seed if seed is not None else int(self._rng.integers(2**31)), spawn)
        self.crashes.clear()
        self._steps = 0
        self.agents = list(self.possible_agents)
        for agent in self._agents.values():
            agent.fresh_sensors()
            agent.reset_progress()
        observations = {name: self._agents[name].observation() for name in self.agents}
        return observations, {name: {"progress": 0.0, "crash": None} for name in self.agents}

    def step(
        self, actions: Mapping[str, np.ndarray]
    ) -> tuple[
        dict[str, dict[str, np.ndarray]], dict[str, float], dict[str, bool], dict[str, bool], dict[str, dict[str, Any]]
    ]:
        """Each live agent's action as its navigation command, the sim run one control period, then per agent:
        observation, reward, termination, truncation, info; terminated and truncated agents leave `agents`."""
        if not isinstance(actions, Mapping):
            raise ConfigError(f"RaceEnv.step: actions must map agent names to actions, got {type(actions).__name__}")
        unknown = [name for name in actions if name not in self._agents]
        if unknown:
            raise ConfigError(f"RaceEnv.step: no agent {unknown[0]!r} (agents: {', '.join(self.possible_agents)})")
        live = list(self.agents)
        checked = {
            name: checked_action(actions[name], self.action_spaces[name], f"RaceEnv.step: {name}")
            for name in live
            if name in actions
        }  # every action checked before any is sent
        for name, action in checked.items():
            self._agents[name].send(action)
        self._steps += 1
        self.sim.run_until(self._steps * self.period_ns / NS_PER_S)
        self.crashes.check(self.sim.data)
        for name in live:
            self._agents[name].after_step()
        index = {name: self.possible_agents.index(name) for name in live}
        car_crash = {name: bool(self.crashes.cars[index[name]]) for name in live}
        if self.collision == "all" and any(car_crash.values()):
            ended = set(live)
        elif self.collision == "none":
            ended = set()
        else:
            ended = {name for name in live if car_crash[name]}
        ended |= {name for name in live if self.crashes.wall[index[name]]}
        observations, rewards, terminations, truncations, infos = {}, {}, {}, {}, {}
        truncate = self._steps >= self.max_cycles
        for name in live:
            agent = self._agents[name]
            progress = agent.step_progress()
            crashed = bool(self.crashes.wall[index[name]]) or car_crash[name]
            observations[name] = agent.observation()
            rewards[name] = float(progress - (self.crash_penalty if name in ended and crashed else 0.0))
            terminations[name] = name in ended
            truncations[name] = truncate and name not in ended
            touched = sorted(self.possible_agents[i] for i in self.crashes.cars[index[name]])
            infos[name] = {
                "progress": progress,
                "crash": "wall" if self.crashes.wall[index[name]] else ("car" if touched else None),
                "cars_touched": touched,
            }
        self.agents = [name for name in live if not (terminations[name] or truncations[name])]
        if self.render_mode == "human":
            self.render()
        return observations, rewards, terminations, truncations, infos

    def render(self) -> np.ndarray | None:
        """rgb_array: the chase camera behind car1; human: the viewer window (where there is a display)."""
        return self._view.render()

    def close(self) -> None:
        """Free the renderers and the cars' cameras."""
        self._view.close()
        for car in self.sim.cars:
            car.close()


def parallel_env(**kwargs: Any) -> RaceEnv:
    """A RaceEnv (PettingZoo's `parallel_env` convention)."""
    return RaceEnv(**kwargs)


race_env = parallel_env
