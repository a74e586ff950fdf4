"""DriveEnv: one RACECAR in a world as a Gymnasium environment (ids racecar_sim/Drive-v0, DriveCamera-v0).

Everything of the stack runs as in `racecar-sim run`: the agent's command is an AckermannDriveStamped on
/vesc/ackermann_cmd_mux/input/navigation, once per control step; the muxes, servo_commands, the joint
controllers and the sensors do the rest. Observations, actions and rewards: see racecar_sim.envs.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from racecar_sim.core.errors import ConfigError
from racecar_sim.core.throttle import is_finite_number
from racecar_sim.core.time import NS_PER_S, to_ns
from racecar_sim.description.vehicle_params import DEFAULT_VEHICLE, VehicleParams, load_vehicle
from racecar_sim.envs.agent import CarAgent, servo_geometry
from racecar_sim.envs.crash import CHECK_RATE, CrashMonitor
from racecar_sim.envs.reward import world_centerline
from racecar_sim.envs.spaces import (
    MAX_SPEED,
    MAX_STEERING,
    DriveLimits,
    check_action_mode,
    checked_action,
)
from racecar_sim.envs.view import EnvView
from racecar_sim.runtime.simulator import Simulator
from racecar_sim.worlds import Spawn, load_world

CONTROL_RATE = 20.0  # Hz
CRASH_PENALTY = 10.0  # reward lost on the step that crashes (10 m of progress)
NAVIGATION_TIMEOUT = 0.2  # s, high_level_mux.yaml's Navigation 0: slower commands let the car stop in between


def spawn_pose(value: Any, z: float = Spawn().z, what: str = "reset options spawn") -> Spawn:
    """options["spawn"]: a Spawn or (x, y, yaw) (or (x, y, z, yaw)) of finite numbers -> Spawn; ConfigError otherwise
    (`what` names the option in the message). Where the pose lies is checked by Simulator.reset (WorldError)."""
    if isinstance(value, Spawn):
        pose = value
    else:
        try:
            numbers = [float(v) for v in value]
        except (TypeError, ValueError):
            numbers = []
        if len(numbers) not in (3, 4):
            raise ConfigError(f"{what}={value!r}: give a Spawn or (x, y, yaw) in m and rad")
        pose = Spawn(numbers[0], numbers[1], z, numbers[2]) if len(numbers) == 3 else Spawn(*numbers)
    for name in ("x", "y", "z", "yaw"):
        number = getattr(pose, name)
        if not is_finite_number(number):
            raise ConfigError(f"{what}={_brief(value)}: {name} must be a finite number, got {number!r}")
    return pose


def _brief(value: Any) -> str:
    """A pose as the user gave it, numpy scalars shown as plain numbers."""
    if isinstance(value, (tuple, list, np.ndarray)):
        return "(" + ", ".join(repr(float(v)) if isinstance(v, (float, np.floating)) else repr(v) for v in value) + ")"
    return repr(value)


class DriveEnv(gym.Env):
    """One car in `world` (a built-in name or a world file), driven through the navigation mux input.

    control_rate: Hz of env steps (each publishes one command and runs the sim 1/control_rate s).
    action: "normalized" (Box(-1, 1)) or "raw" (m/s, rad); max_speed, max_steering: the command range.
    centerline: a CSV the progress reward follows (default: the world's own, see reward.py).
    time_limit: seconds of sim time after which the episode is truncated (None: only max_episode_steps).
    camera: add the camera image to the observation. profile, physics, sensor_noise, vehicle: as for Simulator.
    """

    metadata: dict[str, Any] = {"render_modes": ["rgb_array", "human"], "render_fps": CONTROL_RATE}
    action_space: spaces.Box  # the agent's

    def __init__(
        self,
        world: str | Path = "walker",
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
        vehicle: str | Path | VehicleParams = DEFAULT_VEHICLE,
    ) -> None:
        if not (isinstance(control_rate, (int, float)) and 0 < control_rate < float("inf")):
            raise ConfigError(f"env control_rate must be a positive number of Hz, got {control_rate!r}")
        if 1.0 / control_rate >= NAVIGATION_TIMEOUT:
            raise ConfigError(
                f"env control_rate {control_rate:g} Hz: the navigation mux input times out after "
                f"{NAVIGATION_TIMEOUT:g} s, so commands must come faster than "
                f"{1 / NAVIGATION_TIMEOUT:g} Hz"
            )
        if render_mode not in (None, *self.metadata["render_modes"]):
            raise ConfigError(
                f"env render_mode={render_mode!r} is not one of {', '.join(self.metadata['render_modes'])}"
            )
        if time_limit is not None and not time_limit > 0:
            raise ConfigError(f"env time_limit must be a positive number of seconds, got {time_limit!r}")
        self.action_mode = check_action_mode(action)
        self.limits = DriveLimits(
            MAX_SPEED if max_speed is None else max_speed, MAX_STEERING if max_steering is None else max_steering
        )
        self.period_ns = to_ns(1.0 / control_rate)
        self.metadata = {**self.metadata, "render_fps": control_rate}
        self.crash_penalty = float(crash_penalty)
        self.time_limit_ns = None if time_limit is None else to_ns(time_limit)
        self.camera, self.profile, self.physics, self.sensor_noise = camera, profile, physics, sensor_noise
        self.vehicle = load_vehicle(vehicle)
        self.render_mode = render_mode
        self._centerline_arg = centerline
        self._view: EnvView | None = None
        self._world_key: str | None = None
        self._build(world)
        self.observation_space = self.agent.observation_space
        self.action_space = self.agent.action_space
        self._view = EnvView(render_mode, self.sim)  # RenderingError (one line) at make time where there is no GL

    # --- building ---------------------------------------------------------------------------------
    def _build(self, world: str | Path) -> None:
        """Build the Simulator on `world` (close() the last one first); the spaces stay those of the car (its laser
        and camera)."""
        loaded = load_world(world)
        self.sim = sim = Simulator(
            world=loaded,
            profile=self.profile,
            physics=self.physics,
            camera=self.camera,
            sensor_noise=self.sensor_noise,
            vehicle=self.vehicle,
        )
        self._world_key = str(world)
        self.agent = CarAgent(
            sim,
            sim.car,
            self.action_mode,
            self.limits,
            self.camera,
            world_centerline(loaded, self._centerline_arg),
            self.period_ns,
        )
        geometry = servo_geometry(sim.car)
        self.crashes = CrashMonitor.for_cars(sim.model, [(sim.car.names, sim.car.robot.root, geometry)])
        sim.scheduler.every(CHECK_RATE, lambda now: self.crashes.check(sim.data, now), "env crash check")
        self._steps = 0

    # --- the Gymnasium API ------------------------------------------------------------------------
    def reset(
        self, *, seed: int | None = None, options: Mapping[str, Any] | None = None
    ) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
        """A new episode at the world's spawn pose (or options["spawn"]: a Spawn or (x, y, yaw)), in
        options["world"] if given (the Simulator is rebuilt for a new world; other keys are ignored). `seed` seeds
        the sensor noise; without one, a seed is drawn from the env's generator. Nothing of the last episode is
        left: physics, muxes, controllers (and their integrators) start afresh and the first scan is cast at the
        new pose."""
        options = dict(options or {})
        spawn = options.get("spawn")
        pose = spawn_pose(spawn) if spawn is not None else None  # a malformed pose is refused before anything changes
        super().reset(seed=seed)
        world = options.get("world")
        if world is not None and str(world) != self._world_key:
            self.close()
            self._build(world)
            self._view = EnvView(self.render_mode, self.sim)
        noise_seed = seed if seed is not None else int(self.np_random.integers(2**31))
        self.sim.reset(noise_seed, pose)  # WorldError for a pose off the ground or in a wall: the sim left as it was
        self.crashes.clear()
        self._steps = 0
        self.agent.fresh_sensors()
        self.agent.reset_progress()
        return self.agent.observation(), self._info(0.0)

    def step(self, action: np.ndarray) -> tuple[dict[str, np.ndarray], float, bool, bool, dict[str, Any]]:
        """Publish `action` as the navigation command, run the sim one control period, observe. An action of another
        shape than the action space's, or not numbers, is a ConfigError, a NaN a CommandError (nothing has moved)."""
        sim = self.sim
        self.agent.send(checked_action(action, self.action_space, "DriveEnv.step"))
        self._steps += 1
        sim.run_until(self._steps * self.period_ns / NS_PER_S)
        self.crashes.check(sim.data)
        self.agent.after_step()
        progress = self.agent.step_progress()
        crashed = self.crashes.crashed(0)
        reward = progress - (self.crash_penalty if crashed else 0.0)
        truncated = self.time_limit_ns is not None and sim.time_ns >= self.time_limit_ns
        if self.render_mode == "human":
            self.render()
        return self.agent.observation(), float(reward), crashed, bool(truncated), self._info(progress)

    def _info(self, progress: float) -> dict[str, Any]:
        crash = "wall" if self.crashes.wall[0] else "car" if self.crashes.cars[0] else None
        return {"progress": progress, "crash": crash, "time": self.sim.time}

    def render(self) -> np.ndarray | None:
        """rgb_array: the chase camera's frame; human: the viewer window (where there is a display)."""
        return self._view.render() if self._view is not None else None

    def close(self) -> None:
        """Free the renderers and the Simulator's camera."""
        if self._view is not None:
            self._view.close()
            self._view = None
        if self.sim is not None:
            for car in self.sim.cars:
                car.close()
