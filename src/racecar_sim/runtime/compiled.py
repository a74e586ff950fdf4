"""numba's fast loading of racecar-sim's cached kernels: moved to core/compiled.py (the writer process, in the
recording layer, loads its colour kernel with it too); here for the simulator's and older imports."""

from racecar_sim.core.compiled import _light_loads, load_numba

__all__ = ["_light_loads", "load_numba"]
