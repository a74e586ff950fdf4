"""Physics presets (presets.yaml): step, integrator, solver and contact time constant."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from racecar_sim.core.errors import ConfigError
from racecar_sim.core.tables import read_table, table_entry

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


def preset_names() -> list[str]:
    """Names of the presets."""
    return list(read_table(_FILE))


def load_preset(name: str) -> PhysicsPreset:
    """A preset by name; ConfigError names the file and the preset."""
    preset = table_entry(_FILE, name, PhysicsPreset, "physics preset")
    if preset.wheel_contact not in ("ellipsoid", "cylinder"):
        raise ConfigError(f"{_FILE}: preset '{name}': wheel_contact must be ellipsoid or cylinder")
    if preset.contact_timeconst < 2 * preset.timestep:
        raise ConfigError(f"{_FILE}: preset '{name}': contact_timeconst must be >= 2 * timestep")
    return preset
