"""What an agent sees and does: the observation and action spaces of the driving envs, and the maps between them
and the sim's units. Shared by DriveEnv, RaceEnv, the native batch (envs/batch.py) and the policy driver
(envs/policy.py), which also takes pooled_features: the scan pooled into a few sectors, a small policy's input.

Observation (a `Dict`, every entry float32 unless said):
  scan      (beams,) the latest LaserScan's ranges in m, +inf (nothing within range_max) replaced by range_max,
            so every value lies in [range_min, range_max]. Beams, range_min and range_max come from the car's
            <sensor type="ray"> (the seed's Hokuyo: 1081 beams over +-135 deg, 0.1 .. 10 m, 1 cm noise).
  speed     (1,) forward speed of base_link in m/s (its velocity along the car's heading; negative reversing),
            clipped to +-SPEED_BOUND (twice the 5 m/s the wheels' 100 rad/s joint limit allows).
  steering  (1,) the measured steering angle in rad: the bicycle-model angle atan(L kappa) of the curvature the
            two hinge angles steer (servo `ackermann`), or their mean (servo `parallel`); within (-pi/2, pi/2).
  image     (height, width, 3) uint8 RGB, the ZED camera's latest frame; only with camera=True.

Action: `Box(-1, 1, (2,))` [speed, steering] scaled to [-max_speed, max_speed] m/s and [-max_steering,
max_steering] rad (action="normalized", the default), or the same command in Ackermann units (action="raw":
`Box([-max_speed, -max_steering], [max_speed, max_steering])`). Values outside the box (infinities too) are
clipped; an action of another shape, or not numbers, is refused (ConfigError), and so is a NaN (CommandError). The
defaults are the original's joystick ranges (racecar/config/racecar-v2/joy_teleop.yaml: "plus or minus 2 meters
/ second", "plus or minus ~20 degrees steering angle" = 0.34 rad, also the drivers' max_steering).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from gymnasium import spaces

from racecar_sim.core.errors import CommandError, ConfigError, DescriptionError
from racecar_sim.sensors.camera_spec import CameraSpec
from racecar_sim.sensors.laser_spec import LaserSpec

MAX_SPEED = 2.0  # m/s, joy_teleop.yaml's drive.speed scale
MAX_STEERING = 0.34  # rad, joy_teleop.yaml's drive.steering_angle scale
SPEED_BOUND = 10.0  # m/s, the speed observation's range
ACTION_MODES = ("normalized", "raw")
SCAN, SPEED, STEERING, IMAGE = "scan", "speed", "steering", "image"


@dataclass(frozen=True)
class DriveLimits:
    """The command range an action maps onto: speed in m/s, steering angle in rad (both symmetric)."""

    max_speed: float = MAX_SPEED
    max_steering: float = MAX_STEERING

    def __post_init__(self) -> None:
        for name in ("max_speed", "max_steering"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise ConfigError(f"env {name} must be a positive number, got {value!r}")
        if self.max_steering >= math.pi / 2:
            raise ConfigError(f"env max_steering must be below pi/2 rad, got {self.max_steering!r}")


def check_action_mode(action: str) -> str:
    """`action` if it is one of ACTION_MODES, else ConfigError."""
    if action not in ACTION_MODES:
        raise ConfigError(f"env action={action!r} is not one of {', '.join(ACTION_MODES)}")
    return action


def action_space(action: str = "normalized", limits: DriveLimits = DriveLimits()) -> spaces.Box:
    """The action Box: [speed, steering], normalised to [-1, 1] or in m/s and rad."""
    if check_action_mode(action) == "normalized":
        return spaces.Box(-1.0, 1.0, (2,), np.float32)
    high = np.array([limits.max_speed, limits.max_steering], np.float32)
    return spaces.Box(-high, high, (2,), np.float32)


def action_scale(action: str = "normalized", limits: DriveLimits = DriveLimits()) -> np.ndarray:
    """(2,) float64 factors taking an action to [speed m/s, steering rad] (ones for raw actions)."""
    if check_action_mode(action) == "normalized":
        return np.array([limits.max_speed, limits.max_steering])
    return np.ones(2)


def checked_action(action: object, space: spaces.Box, where: str, shape: tuple[int, ...] | None = None) -> np.ndarray:
    """`action` as a float64 array of `shape` (default: the space's); ConfigError for anything else (not numbers, or
    another shape), CommandError for a NaN. `where`: who takes it ("DriveEnv.step"), for the message. An infinity
    is clipped to the box as any value outside it is."""
    shape = space.shape if shape is None else shape
    try:
        array = np.asarray(action, np.float64)
    except (TypeError, ValueError):
        raise ConfigError(
            f"{where}: action {_brief(action)} is not an array of numbers; the action space is {space}"
        ) from None
    if array.shape != shape:
        expected = (
            f"the action space {space} takes shape {shape}"
            if shape == space.shape
            else f"it takes shape {shape}, a row per world in {space}"
        )
        raise ConfigError(f"{where}: action of shape {array.shape} given; {expected}")
    if np.isnan(array).any():
        raise CommandError(f"{where}: action {_brief(array.tolist())} holds a NaN; the action space is {space}")
    return array


def _brief(value: object, limit: int = 80) -> str:
    """repr(value), cut to `limit` characters (an action may be a large array)."""
    text = " ".join(repr(value).split())
    return text if len(text) <= limit else text[: limit - 3] + "..."


def to_command(actions: np.ndarray, action: str = "normalized", limits: DriveLimits = DriveLimits()) -> np.ndarray:
    """Actions (..., 2) to commands (..., 2) float64 [speed m/s, steering rad], clipped to the limits; works on one
    action or a batch. NaN passes through (the envs refuse it first: checked_action)."""
    scale = action_scale(action, limits)
    bound = np.array([limits.max_speed, limits.max_steering])
    return np.clip(np.asarray(actions, np.float64) * scale, -bound, bound)


def observation_space(laser: LaserSpec, camera: CameraSpec | None = None) -> spaces.Dict:
    """The observation Dict for a car with this laser (and camera, when the env shows images)."""
    entries: dict[str, spaces.Space[np.ndarray]] = {
        SCAN: spaces.Box(np.float32(laser.range_min), np.float32(laser.range_max), (laser.samples,), np.float32),
        SPEED: spaces.Box(-SPEED_BOUND, SPEED_BOUND, (1,), np.float32),
        STEERING: spaces.Box(np.float32(-math.pi / 2), np.float32(math.pi / 2), (1,), np.float32),
    }
    if camera is not None:
        entries[IMAGE] = spaces.Box(0, 255, (camera.height, camera.width, 3), np.uint8)
    return spaces.Dict(entries)


def scan_observation(ranges: np.ndarray, range_max: float, out: np.ndarray | None = None) -> np.ndarray:
    """A LaserScan's ranges (float32, +inf where nothing is in range) as the observation: +inf -> range_max.
    Works on (beams,) or (N, beams); `out` (same shape, float32) is filled and returned when given."""
    if out is None:
        out = np.empty(np.shape(ranges), np.float32)
    np.minimum(ranges, np.float32(range_max), out=out)
    return out


def steering_from_hinges(
    hinge_angles: np.ndarray, hinge_points: np.ndarray, wheelbase: float, servo: str = "ackermann"
) -> np.ndarray:
    """The measured steering angle from the hinge angles (..., H) and the hinges' (x, y) in base_link (H, 2).

    ackermann: each hinge angle h at (x, y) steers the curvature kappa = tan h / (x + y tan h) (formula (2)
    solved for 1/R); their mean kappa gives atan(wheelbase kappa). parallel: the mean hinge angle.
    """
    h = np.asarray(hinge_angles, np.float64)
    if servo == "parallel":
        return h.mean(axis=-1)
    t = np.tan(h)
    kappa = t / (hinge_points[:, 0] + hinge_points[:, 1] * t)
    return np.arctan(wheelbase * kappa.mean(axis=-1))


@lru_cache(maxsize=8)
def default_specs(profile: str = "seed") -> tuple[LaserSpec, CameraSpec | None]:
    """The laser and camera specs of the stock racecar xacro under `profile` (for spaces without a Simulator)."""
    from racecar_sim.control.profiles import load_profile
    from racecar_sim.description import DEFAULT_XACRO, load_robot
    from racecar_sim.runtime.plugins import first_sensor
    from racecar_sim.sensors.lidar import named_laser_spec

    robot = load_robot(DEFAULT_XACRO, load_profile(profile).xacro_args)
    laser, camera = first_sensor(robot, "laser"), first_sensor(robot, "camera")  # the registry's laser, not any ray
    if laser is None:
        raise DescriptionError(f"robot {robot.name} has no laser (is DISABLE_GAZEBO_LASER set?)")
    return named_laser_spec(laser), CameraSpec.from_sensor(camera) if camera is not None else None


def pooled_space(sectors: int) -> spaces.Box:
    """The observation of pooled_features: a float32 vector of sectors + 2."""
    return spaces.Box(-np.inf, np.inf, (sectors + 2,), np.float32)


def pooled_features(
    observation: Mapping[str, np.ndarray], sectors: int, range_max: float, limits: DriveLimits = DriveLimits()
) -> np.ndarray:
    """A driving observation as one small float32 vector (examples/train_ppo.py's policy input): the scan min-pooled
    into `sectors` sectors as np.array_split cuts it (the nearest return in each) over `range_max` (1 = nothing in
    range), then the speed over max_speed and the steering angle over max_steering. Works on one observation
    ((sectors + 2,)) or a batch ((N, sectors + 2)). ConfigError for a sector count the scan cannot give."""
    scan = np.asarray(observation[SCAN], np.float32)
    beams = scan.shape[-1]
    if not (isinstance(sectors, (int, np.integer)) and 1 <= sectors <= beams):
        raise ConfigError(f"pooled features: sectors must be a whole number from 1 to the scan's {beams} beams")
    sizes = [len(part) for part in np.array_split(np.arange(beams), sectors)]
    starts = np.cumsum([0, *sizes[:-1]])
    near = np.minimum.reduceat(scan, starts, axis=-1) / np.float32(range_max)
    scale = np.array([limits.max_speed, limits.max_steering], np.float32)
    motion = np.concatenate([observation[SPEED], observation[STEERING]], axis=-1) / scale
    return np.concatenate([near, motion], axis=-1).astype(np.float32)
