"""Driving profiles (profiles.yaml): which xacro arguments and which servo_commands law a run uses."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from racecar_sim.core.errors import ConfigError
from racecar_sim.core.tables import read_table, table_entry

_FILE = Path(__file__).parent / "data" / "profiles.yaml"


@dataclass(frozen=True)
class Profile:
    """A driving profile: `seed` (default) or `mit-2017`."""

    name: str
    summary: str
    servo: str
    xacro_args: dict[str, str] = field(default_factory=dict)
    wheel_rate_per_speed: float | None = None

    def __post_init__(self) -> None:
        where = f"{_FILE}: profile '{self.name}'"
        if self.servo not in ("ackermann", "parallel"):
            raise ConfigError(f"{where}: servo must be ackermann or parallel, got {self.servo!r}")
        if self.wheel_rate_per_speed is not None and self.wheel_rate_per_speed <= 0:
            raise ConfigError(f"{where}: wheel_rate_per_speed must be positive, got {self.wheel_rate_per_speed:g}")
        if not all(isinstance(k, str) and isinstance(v, str) for k, v in self.xacro_args.items()):
            raise ConfigError(f"{where}: xacro_args must map names to strings")


def profile_names() -> list[str]:
    """Names of the driving profiles."""
    return list(read_table(_FILE))


def load_profile(name: str) -> Profile:
    """A profile by name; ConfigError lists the known ones."""
    return table_entry(_FILE, name, Profile, "profile")
