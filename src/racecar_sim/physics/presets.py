"""Physics presets (presets.yaml): step, integrator, solver and contact time constant."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import mujoco

from racecar_sim.core.errors import ConfigError
from racecar_sim.core.tables import read_table, table_entry

_FILE = Path(__file__).parent / "data" / "presets.yaml"
INTEGRATORS = {
    "euler": mujoco.mjtIntegrator.mjINT_EULER,
    "implicitfast": mujoco.mjtIntegrator.mjINT_IMPLICITFAST,
    "implicit": mujoco.mjtIntegrator.mjINT_IMPLICIT,
    "rk4": mujoco.mjtIntegrator.mjINT_RK4,
}
SOLVERS = {"newton": mujoco.mjtSolver.mjSOL_NEWTON, "cg": mujoco.mjtSolver.mjSOL_CG, "pgs": mujoco.mjtSolver.mjSOL_PGS}
CONES = {"pyramidal": mujoco.mjtCone.mjCONE_PYRAMIDAL, "elliptic": mujoco.mjtCone.mjCONE_ELLIPTIC}


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
    where = f"{_FILE}: preset '{name}'"
    for field, choices in (
        ("integrator", INTEGRATORS),
        ("solver", SOLVERS),
        ("cone", CONES),
        ("wheel_contact", ("ellipsoid", "cylinder")),
    ):
        if getattr(preset, field) not in choices:
            raise ConfigError(f"{where}: {field} must be one of {', '.join(choices)}, got {getattr(preset, field)!r}")
    if preset.timestep <= 0 or preset.iterations < 1:
        raise ConfigError(f"{where}: timestep must be positive and iterations at least 1")
    if preset.contact_timeconst < 2 * preset.timestep:
        raise ConfigError(f"{_FILE}: preset '{name}': contact_timeconst must be >= 2 * timestep")
    return preset
