"""Gymnasium and PettingZoo environments on the racecar simulator (import this module to register them).

Ids (Gymnasium, registered on import; `gym.make(ID, world=..., ...)`):
  racecar_sim/Drive-v0        one car, lidar observation (scan, speed, steering); world "walker" by default.
  racecar_sim/DriveCamera-v0  the same plus the ZED camera image (needs a headless OpenGL context).
Both stop (truncated) after max_episode_steps = 1200 control steps (60 s at 20 Hz); DriveEnv's own `time_limit`
(seconds) truncates as well. Every keyword of DriveEnv (drive.py) passes through gym.make: world (a built-in
name or a world file), centerline, control_rate (20 Hz), action ("normalized" | "raw"), max_speed (2 m/s),
max_steering (0.34 rad), crash_penalty (10), profile, physics, sensor_noise, render_mode ("rgb_array" | "human"),
vehicle (a vehicle set: "seed", "f1tenth" or a YAML file; both batches take it too, the Warp one as Warp kernels).

Vector (Gymnasium): `gym.make_vec("racecar_sim/Drive-v0", num_envs=N)` gives the native batch DriveBatch (batch.py;
vectorization_mode "vector_entry_point", Gymnasium's default for this id), a gymnasium.vector.VectorEnv with SAME_STEP
autoreset; vectorization_mode="sync" / "async" vectorise DriveEnv instead (DriveCamera-v0 always does).
Stable-Baselines3: `racecar_sim.envs.sb3.SB3VecEnv(batch)` (imported only there, needs the [rl] extra).

PettingZoo: `racecar_sim.envs.parallel_env(num_cars=2, world="walker", collision="involved", ...)` (also
`race_env`) gives a RaceEnv (race.py), a ParallelEnv with agents "car1", "car2", ...

Observation (spaces.py, one per car):
  scan      float32 (1081,): the latest /scan ranges in m, +inf replaced by range_max (10 m); in [0.1, 10].
  speed     float32 (1,): base_link's forward speed, m/s.
  steering  float32 (1,): the measured steering angle, rad (the bicycle angle of the hinges' curvature).
  image     uint8 (480, 640, 3) RGB: the camera's latest frame (DriveCamera-v0 / camera=True only).
Action: float32 Box(-1, 1, (2,)) = [speed, steering] x [max_speed 2.0 m/s, max_steering 0.34 rad] (the
original joy_teleop ranges); action="raw" takes the same in m/s and rad. The command enters as an
AckermannDriveStamped on /vesc/ackermann_cmd_mux/input/navigation (per car: /<car>/vesc/...) every control step.
Reward per step: metres of progress along the world's centerline (reward.py: World.centerline, a track CSV's own or
walker's, or `centerline=CSV`; else the distance driven along the heading) minus crash_penalty on the step that
crashes. Terminated: the car touches a wall, an obstacle or another car (any contact of a car geom with something
not itself, except a wheel resting on a surface whose normal points up, |n_z| > 0.7). Truncated: time limit.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from gymnasium.envs.registration import register, registry

from racecar_sim.envs.spaces import (
    MAX_SPEED,
    MAX_STEERING,
    DriveLimits,
    action_space,
    observation_space,
)

if TYPE_CHECKING:  # loaded by __getattr__ below when first asked for
    from racecar_sim.envs.batch import DriveBatch
    from racecar_sim.envs.drive import DriveEnv
    from racecar_sim.envs.race import RaceEnv, parallel_env, race_env

DRIVE_ID = "racecar_sim/Drive-v0"
DRIVE_CAMERA_ID = "racecar_sim/DriveCamera-v0"
MAX_EPISODE_STEPS = 1200  # 60 s at the default 20 Hz control rate
ENV_IDS = (DRIVE_ID, DRIVE_CAMERA_ID)

__all__ = [
    "DRIVE_CAMERA_ID",
    "DRIVE_ID",
    "ENV_IDS",
    "MAX_EPISODE_STEPS",
    "MAX_SPEED",
    "MAX_STEERING",
    "DriveBatch",
    "DriveEnv",
    "DriveLimits",
    "RaceEnv",
    "action_space",
    "observation_space",
    "parallel_env",
    "race_env",
]


def _register() -> None:
    # Drive-v0's vector entry point is the native batch (it has no camera: DriveCamera-v0 vectorises DriveEnv)
    for env_id, kwargs, vector in (
        (DRIVE_ID, {}, "racecar_sim.envs.batch:DriveBatch"),
        (DRIVE_CAMERA_ID, {"camera": True}, None),
    ):
        if env_id not in registry:
            register(
                env_id,
                entry_point="racecar_sim.envs.drive:DriveEnv",
                vector_entry_point=vector,
                kwargs=kwargs,
                max_episode_steps=MAX_EPISODE_STEPS,
            )


_register()


def __getattr__(name: str) -> object:  # the env classes load the simulator: only when asked for
    if name == "DriveEnv":
        from racecar_sim.envs.drive import DriveEnv

        return DriveEnv
    if name == "DriveBatch":
        from racecar_sim.envs.batch import DriveBatch

        return DriveBatch
    if name in ("RaceEnv", "race_env", "parallel_env"):
        from racecar_sim.envs import race

        return getattr(race, name)
    raise AttributeError(f"module 'racecar_sim.envs' has no attribute {name!r}")
