"""Physics presets (presets.yaml): step, integrator, solver and contact time constant."""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

import yaml

from racecar_sim.core.errors import ConfigError

_FILE = Path(__file__).parent / "data" / "presets.yaml"


@dataclass(frozen=True)
class PhysicsPreset:
    """Free parameters of the physics: chosen by the fidelity tests, not by the original stack."""

    name: str
    timestep: float
    integrator: str
    solver: str
    iterations: int
    cone: str
    contact_timeconst: float
    wheel_contact: str = "ellipsoid"


@lru_cache(maxsize=1)
def _presets() -> dict[str, dict]:
    return yaml.safe_load(_FILE.read_text())


def preset_names() -> list[str]:
    """Names of the presets."""
    return list(_presets())


def load_preset(name: str) -> PhysicsPreset:
    """A preset by name; ConfigError names the file and the preset."""
    presets = _presets()
    if name not in presets:
        raise ConfigError(f"{_FILE}: no physics preset '{name}' (have: {', '.join(presets)})")
    preset = PhysicsPreset(name=name, **presets[name])
    if preset.wheel_contact not in ("ellipsoid", "cylinder"):
        raise ConfigError(f"{_FILE}: preset '{name}': wheel_contact must be ellipsoid or cylinder")
    if preset.contact_timeconst < 2 * preset.timestep:
        raise ConfigError(f"{_FILE}: preset '{name}': contact_timeconst must be >= 2 * timestep")
    return preset
