"""Vehicle parameter sets: tyre and actuator parameters in F1TENTH's names, the body staying the description's.

A set is a YAML mapping with f1tenth_gym's parameter names (`mu`, `C_Sf`, `C_Sr`, `s_min`, `s_max`, `sv_min`,
`sv_max`, `a_max`, `v_min`, `v_max`, ...) and, optionally, Pacejka magic-formula coefficients `[B, C, D, E]` for the
front and rear tyres as ForzaETH's race stack writes them (`C_Pf`, `C_Pr`). Shipped sets: `seed` (the seed's car,
no tyre model) and `f1tenth` (F1TENTH's published parameters). F1TENTH's body parameters (`lf`, `lr`, `h`, `m`, `I`,
`width`, `length`) are accepted and not read: the description gives the body.

Tyre model of a set: `pacejka` where C_Pf and C_Pr are given, else `linear` where C_Sf and C_Sr are, else none
(MuJoCo's Coulomb contact at the wheels, as the seed).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields
from pathlib import Path
from typing import Any

import yaml

from racecar_sim.core.errors import ConfigError
from racecar_sim.core.tables import finite_number

_DIR = Path(__file__).parent / "data" / "vehicles"
DEFAULT_VEHICLE = "seed"
_BODY = ("lf", "lr", "h", "m", "I", "width", "length")  # F1TENTH's body: the description's here
_PACEJKA = {
    "C_Pf": "pacejka_front",
    "C_Pr": "pacejka_rear",
    "C_Pf_model": "pacejka_front",
    "C_Pr_model": "pacejka_rear",
}

Pacejka = tuple[float, float, float, float]  # B, C, D, E


@dataclass(frozen=True)
class VehicleParams:
    """One vehicle set: tyre (mu, C_Sf, C_Sr per rad normalised by load, Pacejka B C D E) and actuator limits
    (steering angle s_min..s_max rad, steering rate sv_min..sv_max rad/s, acceleration a_max m/s², speed
    v_min..v_max m/s). None: not limited / not given."""

    name: str
    mu: float = 1.0
    C_Sf: float | None = None
    C_Sr: float | None = None
    pacejka_front: Pacejka | None = None
    pacejka_rear: Pacejka | None = None
    s_min: float | None = None
    s_max: float | None = None
    sv_min: float | None = None
    sv_max: float | None = None
    a_max: float | None = None
    v_min: float | None = None
    v_max: float | None = None
    v_switch: float | None = None

    @property
    def tyre_model(self) -> str:
        """'pacejka', 'linear' or 'none' (MuJoCo's Coulomb contact at the wheels)."""
        if self.pacejka_front is not None and self.pacejka_rear is not None:
            return "pacejka"
        if self.C_Sf is not None and self.C_Sr is not None:
            return "linear"
        return "none"

    @property
    def understeer_gradient(self) -> float:
        """rad/g, the single-track model's K = (1/mu) (1/C_Sf - 1/C_Sr) of the linear tyres (0 without)."""
        if self.C_Sf is None or self.C_Sr is None:
            return 0.0
        return (1.0 / self.C_Sf - 1.0 / self.C_Sr) / self.mu


def vehicle_names() -> list[str]:
    """Names of the shipped vehicle sets."""
    return sorted(p.stem for p in _DIR.glob("*.yaml"))


def load_vehicle(name_or_file: str | Path | VehicleParams = DEFAULT_VEHICLE) -> VehicleParams:
    """A shipped set by name, or a YAML file of one; ConfigError (one line) names the file and the field at fault."""
    if isinstance(name_or_file, VehicleParams):
        return name_or_file
    text = str(name_or_file)
    if text in vehicle_names():
        path, name = _DIR / f"{text}.yaml", text
    elif text.endswith((".yaml", ".yml")) or Path(text).is_file():
        path, name = Path(text), Path(text).stem
    else:
        raise ConfigError(f"unknown vehicle {text!r} (choose from: {', '.join(vehicle_names())}, or a YAML file)")
    try:
        content = path.read_text()
        known = _PARSED.get((name, str(path), content))
        if known is not None:  # every car of a fleet reads the same set: parsed once (1.5 ms of YAML a car)
            return known
        data = yaml.safe_load(content)
    except (OSError, yaml.YAMLError) as exc:
        raise ConfigError(f"{path}: cannot read: {' '.join(str(exc).split())}") from None
    if data is None:
        data = {}
    if not isinstance(data, dict):
        raise ConfigError(f"{path}: expected a mapping of F1TENTH parameter names to values")
    params = _PARSED[(name, str(path), content)] = _params(name, data, path)
    return params


# load_vehicle's sets by (name, path, the file's text): a VehicleParams is frozen, and the same text gives the same set
_PARSED: dict[tuple[str, str, str], VehicleParams] = {}


def _params(name: str, data: dict[Any, Any], path: Path) -> VehicleParams:
    known = {f.name for f in fields(VehicleParams)} - {"name", "pacejka_front", "pacejka_rear"}
    values: dict[str, Any] = {}
    for key, value in data.items():
        where = f"{path}: {key}"
        if key in _BODY:
            finite_number(value, where)
        elif key in _PACEJKA:
            values[_PACEJKA[key]] = _pacejka(value, where)
        elif key in known:
            values[key] = finite_number(value, where)
        else:
            raise ConfigError(
                f"{path}: unknown field {key!r} (F1TENTH's names: {', '.join(sorted(known | set(_BODY)))})"
            )
    for key in ("mu", "C_Sf", "C_Sr", "sv_max", "a_max", "v_max"):
        if key in values and values[key] <= 0:
            raise ConfigError(f"{path}: {key} must be positive, got {values[key]:g}")
    for low, high in (("s_min", "s_max"), ("sv_min", "sv_max"), ("v_min", "v_max")):
        if low in values and high in values and not values[low] < values[high]:
            raise ConfigError(f"{path}: {low} ({values[low]:g}) must be below {high} ({values[high]:g})")
    if ("pacejka_front" in values) != ("pacejka_rear" in values):
        raise ConfigError(f"{path}: C_Pf and C_Pr: give the Pacejka coefficients of both axles, or neither")
    if ("C_Sf" in values) != ("C_Sr" in values):
        raise ConfigError(f"{path}: C_Sf and C_Sr: give the cornering stiffness of both axles, or neither")
    return VehicleParams(name=name, **values)


def _pacejka(value: Any, where: str) -> Pacejka:
    """[B, C, D, E] as ForzaETH writes them (a list of four numbers; B, C, D positive)."""
    if not isinstance(value, (list, tuple)) or len(value) != 4:
        raise ConfigError(f"{where}: expected [B, C, D, E], four numbers, got {value!r}")
    b, c, d, e = (finite_number(v, where) for v in value)
    if min(b, c, d) <= 0 or not math.isfinite(e):
        raise ConfigError(f"{where}: B, C and D must be positive, got {value!r}")
    return b, c, d, e
