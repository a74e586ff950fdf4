"""Colours of Gazebo's stock material scripts (Gazebo/Grey, ...), from gazebo_materials.yaml."""

from __future__ import annotations

import warnings
from functools import lru_cache
from pathlib import Path

from racecar_sim.core import yaml_text


@lru_cache(maxsize=1)
def _table() -> dict[str, tuple[float, float, float, float]]:
    data = yaml_text.safe_load((Path(__file__).parent / "data" / "gazebo_materials.yaml").read_text())
    return {name: tuple(rgba) for name, rgba in data.items()}


def gazebo_material_rgba(name: str) -> tuple[float, float, float, float]:
    """RGBA of a Gazebo material script name; unknown names warn and give grey."""
    table = _table()
    if name not in table:
        warnings.warn(f"Gazebo material '{name}' is unknown; using Gazebo/Grey", stacklevel=2)
        return table["Gazebo/Grey"]
    return table[name]
