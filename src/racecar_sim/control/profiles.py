"""Driving profiles (profiles.yaml): which xacro arguments and which servo_commands law a run uses."""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import lru_cache
from pathlib import Path

import yaml

from racecar_sim.core.errors import ConfigError

_FILE = Path(__file__).parent / "data" / "profiles.yaml"


@dataclass(frozen=True)
class Profile:
    """A driving profile: `seed` (default) or `mit-2017`."""

    name: str
    summary: str
    servo: str
    xacro_args: dict[str, str] = field(default_factory=dict)
    wheel_rate_per_speed: float | None = None


@lru_cache(maxsize=1)
def _profiles() -> dict[str, dict]:
    return yaml.safe_load(_FILE.read_text())


def profile_names() -> list[str]:
    """Names of the driving profiles."""
    return list(_profiles())


def load_profile(name: str) -> Profile:
    """A profile by name; ConfigError lists the known ones."""
    profiles = _profiles()
    if name not in profiles:
        raise ConfigError(f"unknown profile '{name}' (choose from: {', '.join(profiles)})")
    return Profile(name=name, **profiles[name])
