"""numba loaded once, when a simulator that will use its kernels is built, and without SciPy's linear algebra.

numba's first compile or cache load registers its implementations, and one of them (numba/np/arraymath.py) imports
scipy.linalg only to learn whether a BLAS exists for np.correlate / np.convolve: 0.2-0.7 s of a walker run's start,
for kernels that call neither. Here that import is refused while numba registers (in this thread only), and the
answer it would have given is put back: whether SciPy is installed. np.dot and np.linalg in a later kernel import
scipy.linalg themselves, at their own compile, as they always do. Anything unexpected (another numba) falls back
to numba's own load.
"""

from __future__ import annotations

import importlib.abc
import importlib.util
import sys
import threading
from collections.abc import Sequence
from types import ModuleType

_done = False


class _NoSciPy(importlib.abc.MetaPathFinder):
    """Refuses `scipy` and its submodules to one thread, while numba registers its implementations."""

    def __init__(self) -> None:
        self.thread = threading.get_ident()

    def find_spec(
        self, fullname: str, path: Sequence[str] | None, target: ModuleType | None = None
    ) -> importlib.machinery.ModuleSpec | None:
        if (fullname == "scipy" or fullname.startswith("scipy.")) and threading.get_ident() == self.thread:
            raise ImportError(f"{fullname}: not while numba registers (racecar_sim.runtime.compiled)")
        return None


def load_numba() -> None:
    """Import numba and register its CPU implementations now (once per process; numba's cached kernels then load
    in milliseconds each)."""
    global _done
    if _done:
        return
    _done = True
    if "scipy.linalg" in sys.modules or "numba.np.arraymath" in sys.modules:
        return  # nothing to save: SciPy's linear algebra or numba's registries are already there
    blocker = _NoSciPy()
    sys.meta_path.insert(0, blocker)
    try:
        from numba.core.registry import cpu_target

        cpu_target.target_context.refresh()  # what a dispatcher's first compile or cache load does first
    finally:
        sys.meta_path.remove(blocker)
    arraymath = sys.modules.get("numba.np.arraymath")
    if arraymath is not None and hasattr(arraymath, "_HAVE_BLAS"):
        setattr(arraymath, "_HAVE_BLAS", importlib.util.find_spec("scipy") is not None)  # noqa: B010 (numba's own)
