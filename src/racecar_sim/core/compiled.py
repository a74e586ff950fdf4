"""numba loaded once, when a simulator that will use its kernels is built: racecar-sim's cached kernels linked in
without numba's registration of its compiler's implementations, and without SciPy's linear algebra.

Before loading a cached kernel, numba refreshes its compiler's registries: it imports some 200 modules of typing
and lowering implementations (0.4-0.8 s of a walker run's start on a 2-core machine), none of which a kernel that
is already compiled needs. Running one needs only what its machine code links against: numba's C helpers (put in
the linker's table when numba's target context is made), the runtime's (NRT) functions, and the hash secret of
kernels that hash (numba.cpython.hashing). So a kernel of racecar-sim's own (`_OURS`) is loaded after just those;
anything else numba loads, and every compile (a cache miss: numba's compiler refreshes the registries itself, as
it always does), goes numba's own way. A numba whose cache is not laid out as this expects is left as it is.

Where the registries are loaded (that numba, or a compile), one of them (numba/np/arraymath.py) imports
scipy.linalg only to learn whether a BLAS exists for np.correlate / np.convolve (0.2-0.7 s): here that import is
refused while numba registers (in this thread only), and the answer it would have given is put back: whether SciPy
is installed. np.dot and np.linalg in a later kernel import scipy.linalg themselves, at their own compile, as they
always do. SciPy is refused to numba's own import too, which imports it only to check its version.
"""

from __future__ import annotations

import importlib.abc
import importlib.util
import sys
import threading
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from types import ModuleType
from typing import Any

# the modules whose cached kernels load without the registries: racecar-sim's, and the tyre kernels' generated copy
_OURS = ("racecar_sim.", "racecar_tyre_kernels_")

_done = False
_loading = threading.local()  # .ours: one of racecar-sim's kernels is being loaded, on this thread


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


@contextmanager
def _scipy_refused() -> Iterator[None]:
    """Inside, this thread cannot import SciPy."""
    blocker = _NoSciPy()
    sys.meta_path.insert(0, blocker)
    try:
        yield
    finally:
        sys.meta_path.remove(blocker)


def load_numba() -> None:
    """Import numba and make its cached kernels of racecar-sim load without its compiler's registries (once per
    process; each kernel then loads in milliseconds)."""
    global _done
    if _done:
        return
    _done = True
    if "scipy" not in sys.modules:
        with _scipy_refused():  # numba's import only checks SciPy's version, where SciPy imports (13 modules, 30 ms)
            import numba  # noqa: F401
    from numba.core import caching

    if _light_loads(caching.Cache):
        return
    _register()  # a numba laid out otherwise: its registries now, as a first cache load would


def _light_loads(cache_class: Any) -> bool:
    """Make `cache_class.load_overload` load racecar-sim's kernels without the registries; False where this numba's
    Cache lacks what that needs (nothing changed then)."""
    original = getattr(cache_class, "load_overload", None)
    needed = ("_load_overload", "_guard_against_spurious_io_errors")
    if original is None or not all(hasattr(cache_class, name) for name in needed):
        return False
    if getattr(original, "racecar_sim_light", False):
        return True

    def load_overload(self: Any, sig: Any, target_context: Any) -> Any:
        module = getattr(getattr(self, "_py_func", None), "__module__", None) or ""
        if not module.startswith(_OURS):
            return original(self, sig, target_context)
        _ready_to_link(target_context)
        _loading.ours = True
        try:
            with self._guard_against_spurious_io_errors():
                return self._load_overload(sig, target_context)
        finally:
            _loading.ours = False

    load_overload.racecar_sim_light = True  # type: ignore[attr-defined]
    cache_class.load_overload = load_overload
    _light_environments()
    return True


def _light_environments() -> None:
    """Rebuild the environments of numba's own functions inlined in racecar-sim's kernels without importing their
    modules.

    A cached kernel's pickled result holds an environment for every function compiled into it, numba's own
    implementations among them (numba.np.arrayobj, numba.cpython.unicode, ...), and numba rebuilds each one around
    its module's globals, importing the module: 11 modules of numba's lowering code, 0.05 s of a camera run's start.
    An environment's globals serve only object mode, which no kernel here uses (they are all njit: nopython), and
    its constants are pickled with it. So, while one of racecar-sim's kernels loads, an environment without
    constants whose module is numba's and not imported is rebuilt around a globals dict of just its module's name
    (what pickling it again reads); anything else is rebuilt numba's way. A numba without `_rebuild_env` is left
    as it is."""
    from numba.core import environment

    original = getattr(environment, "_rebuild_env", None)
    if original is None or getattr(original, "racecar_sim_light", False):
        return

    def _rebuild_env(modname: str, consts: Any, env_name: str) -> Any:
        light = getattr(_loading, "ours", False) and not consts and modname.startswith("numba.")
        known = environment.lookup_environment(env_name)  # type: ignore[no-untyped-call]
        if not light or modname in sys.modules or known is not None:
            return original(modname, consts, env_name)
        env = environment.Environment({"__name__": modname})
        env.env_name = env_name
        environment.Environment._memo[env_name] = env
        return env

    # pickled by numba's name (Environment.__reduce__ returns the module's `_rebuild_env`: this one)
    _rebuild_env.__module__, _rebuild_env.__qualname__ = original.__module__, original.__qualname__
    _rebuild_env.racecar_sim_light = True  # type: ignore[attr-defined]
    environment._rebuild_env = _rebuild_env


def _ready_to_link(target_context: Any) -> None:
    """What a compiled kernel's machine code links against, besides the C helpers the target context put in the
    linker's table when it was made: the runtime's functions and the hash secret."""
    import numba.cpython.hashing  # noqa: F401 - its import puts the hash secret in the linker's table
    from numba.core.runtime import rtsys

    rtsys.initialize(target_context)  # once per process; numba's own refresh starts with it


def _register() -> None:
    """numba's registries loaded now (what its first compile or cache load does first), without SciPy."""
    if "scipy.linalg" in sys.modules or "numba.np.arraymath" in sys.modules:
        return  # nothing to save: SciPy's linear algebra or numba's registries are already there
    with _scipy_refused():
        from numba.core.registry import cpu_target

        cpu_target.target_context.refresh()
    arraymath = sys.modules.get("numba.np.arraymath")
    if arraymath is not None and hasattr(arraymath, "_HAVE_BLAS"):
        setattr(arraymath, "_HAVE_BLAS", importlib.util.find_spec("scipy") is not None)  # noqa: B010 (numba's own)
