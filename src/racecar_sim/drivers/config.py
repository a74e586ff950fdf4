"""Driver settings: a YAML file of defaults (drivers/data), overridable field by field."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from racecar_sim.core.errors import ConfigError
from racecar_sim.core.tables import load_record

DATA = Path(__file__).parent / "data"


@dataclass(frozen=True)
class WallFollowConfig:
    """wall_follow.yaml: which wall, how far, the PID gains and the speed law."""

    side: str
    distance: float
    sector: tuple[float, float]
    patch: float
    lookahead: float
    lookahead_time: float
    kp: float
    ki: float
    kd: float
    max_approach: float
    max_steering: float
    speed: float
    min_speed: float
    front_cone: float
    front_turn: float
    front_slow: float
    front_min: float
    stuck: float
    reverse_time: float

    def __post_init__(self) -> None:
        if self.side not in ("right", "left"):
            raise ConfigError(f"wall-follow side must be right or left, got {self.side!r}")
        if len(self.sector) != 2 or not 0 <= self.sector[0] < self.sector[1] <= 180:
            raise ConfigError(
                f"wall-follow sector must be [from, to] deg with 0 <= from < to <= 180, got {self.sector}"
            )
        _positive(self, "patch", "distance", "max_approach", "max_steering", "speed", "min_speed", "front_cone")


@dataclass(frozen=True)
class PurePursuitConfig:
    """pure_pursuit.yaml: the look-ahead law, the car's wheelbase and the speed law."""

    lookahead: float
    lookahead_time: float
    min_lookahead: float
    max_lookahead: float
    wheelbase: float
    max_steering: float
    speed: float
    min_speed: float
    max_lateral_accel: float

    def __post_init__(self) -> None:
        _positive(self, "min_lookahead", "max_lookahead", "wheelbase", "max_steering", "speed", "max_lateral_accel")


def _positive(config: object, *names: str) -> None:
    for name in names:
        if getattr(config, name) <= 0:
            raise ConfigError(f"{type(config).__name__}: {name} must be positive, got {getattr(config, name)}")


def wall_follow_config(path: Path = DATA / "wall_follow.yaml", /, **overrides: object) -> WallFollowConfig:
    """The wall-follow settings from `path`, with keyword overrides (None = keep the file's value)."""
    return load_record(path, WallFollowConfig, overrides)


def pure_pursuit_config(path: Path = DATA / "pure_pursuit.yaml", /, **overrides: object) -> PurePursuitConfig:
    """The pure-pursuit settings from `path`, with keyword overrides (None = keep the file's value)."""
    return load_record(path, PurePursuitConfig, overrides)
