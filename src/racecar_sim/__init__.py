"""racecar-sim: the MIT RACECAR simulator on MuJoCo, without ROS or Gazebo.

    from racecar_sim import Simulator
    sim = Simulator(world="empty", profile="seed", seed=0)

Importing the package does nothing else: `Simulator`, `Car` and `Spawn` are imported on first use (PEP 562), so
`import racecar_sim.msgs` or `racecar_sim.core` loads neither MuJoCo nor the mesh libraries.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

__version__ = "0.1.0"

_LAZY = {"Car": "racecar_sim.runtime", "Simulator": "racecar_sim.runtime", "Spawn": "racecar_sim.worlds"}

__all__ = ["Car", "Simulator", "Spawn", "__version__"]

if TYPE_CHECKING:
    from racecar_sim.runtime import Car, Simulator
    from racecar_sim.worlds import Spawn


def __getattr__(name: str) -> Any:
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'racecar_sim' has no attribute {name!r}")
    if module == "racecar_sim.runtime":
        from racecar_sim.render.gl import guard_mujoco_import

        guard_mujoco_import()  # the runtime imports mujoco: a MUJOCO_GL backend without its library must not break it
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted({*globals(), *_LAZY})
