"""The tyre forces as MuJoCo's passive-force callback, compiled (numba `cfunc`): no Python runs in the physics step.

MuJoCo calls `mjcb_passive(m, d)` at the end of its passive forces, in every step of every model of the process. The
callback looks for tyre tables among the model's custom numerics (a table starts with MAGIC; runtime fills it after
each compile); a model without one (every `seed` car, any other model) gets nothing added, bit for bit. Per wheel of
a table it reads, from the mjData: the wheel body's pose (xpos, xmat) and velocity (cvel about subtree_com), the
wheel's normal load (a touch sensor of the previous step's contact forces), and adds the tyre force at the contact
point with mj_applyFT to qfrc_passive.

The callback reaches mjModel and mjData fields through their C struct's layout. The bindings do not publish the
offsets, so they are measured once per process from probe models: a pointer field is where the struct holds the
address of the array the bindings show (in every probe; the last of a run of empty arrays sharing the address;
read a chunk at a time, never far past the field), a size field where it changes as a probe's size does. A layout
the probe cannot pin down is an error naming the field, never a guess.

The tyre: slip ratio kappa = -s_x / max(V, |omega r|, v_eps_x) (bounded: a spinning or locked wheel is |kappa| = 1,
where a Pacejka curve fitted for slip angles has not turned negative yet) and slip angle
alpha = atan(-s_y / max(V, v_eps_y)), s the velocity of the wheel's material at the contact point along the wheel's
heading and across it, V the wheel centre's speed along its heading. Force per axis: linear mu C_S F_z x, or Pacejka
F_z D sin(C atan(B x - E (B x - atan B x))); combined within the friction ellipse (a circle of radius mu F_z, D F_z for
Pacejka). v_eps keeps the force bounded and the explicit step stable at walking speed (below it the tyre is a viscous
contact); the longitudinal force per slip speed is also capped at half the wheel's spin inertia / (r^2 dt), the
stiffest the explicit step keeps stable.
"""

from __future__ import annotations

import ctypes
import importlib.util
import os
import sys
import tempfile
from functools import cache
from pathlib import Path
from types import ModuleType
from typing import Any

import mujoco
import numpy as np

MAGIC = 7_311_993.0  # first value of a tyre table
HEADER = 3  # MAGIC, number of wheels, the address of mj_applyFT
STRIDE = 20  # values per wheel
# per wheel: body, root body, touch sensor address, radius, spin axis in the body frame (3), model (1 linear,
# 2 Pacejka), mu, C_S, B, C, D, E, v_eps_x, v_eps_y, tyre centre in the body frame (3), the
# largest longitudinal force per slip speed the explicit step keeps stable on the wheel's spin (N s/m)
LINEAR, PACEJKA = 1.0, 2.0
DYNPRM_SIZE = mujoco.mjNDYN

_DATA_POINTERS = ("xpos", "xmat", "cvel", "subtree_com", "sensordata", "qfrc_passive", "ctrl", "act")
_MODEL_POINTERS = ("numeric_adr", "numeric_data", "actuator_actadr", "actuator_dynprm")


class LayoutError(RuntimeError):
    """The struct layout of this MuJoCo could not be measured."""


def _raw(address: int, size: int) -> np.ndarray:
    return np.frombuffer(ctypes.string_at(address, size), np.int64)


_CHUNK = 256  # bytes read at a time: a scan stops within one chunk past the last field it looks for
_LIMIT = 1 << 20  # bytes: no struct of MuJoCo's is this large


def _struct_offsets(struct: Any, names: tuple[str, ...]) -> dict[str, int]:
    """Byte offset of each pointer field `names` in one struct: where it holds the address of the array the bindings
    show. Empty arrays just before a field share its address (MuJoCo's arena): the field is the last of that run.
    The struct is read a chunk at a time, and no further than a chunk past the run of the last field (reading past
    the end of the struct's memory would crash the process)."""
    wanted = {name: getattr(struct, name).ctypes.data for name in names}
    runs: dict[str, list[int]] = {}  # consecutive word indices holding the address
    done: set[str] = set()
    offset = 0
    while len(done) < len(wanted):
        if offset >= _LIMIT:
            missing = ", ".join(sorted(set(wanted) - done))
            raise LayoutError(f"mujoco {mujoco.__version__}: cannot locate field {missing} of the C struct")
        words = _raw(struct._address + offset, _CHUNK)
        for name, address in wanted.items():
            if name in done:
                continue
            hits = (np.nonzero(words == address)[0] + offset // 8).tolist()
            run = runs.setdefault(name, [])
            if run and (not hits or hits[0] != run[-1] + 1):
                done.add(name)  # the run of equal addresses ended at the chunk's edge
                continue
            run += hits
            if hits and hits[-1] < offset // 8 + len(words) - 1:
                done.add(name)  # ... or within the chunk
        offset += _CHUNK
    return {name: 8 * max(run) for name, run in runs.items()}


def _pointer_offsets(structs: list[Any], names: tuple[str, ...]) -> dict[str, int]:
    """Byte offset of each pointer field `names` in the structs (all of one type): the same in every probe."""
    found = [_struct_offsets(s, names) for s in structs]
    for name in names:
        if len({f[name] for f in found}) != 1:
            raise LayoutError(f"mujoco {mujoco.__version__}: field {name} of the C struct is ambiguous")
    return found[0]


def _probe_model(n: int) -> mujoco.MjModel:
    numerics = "".join(f"<numeric name='n{i:03d}' data='1 2 3 4 5 6 7'/>" for i in range(n))
    return mujoco.MjModel.from_xml_string(
        "<mujoco><worldbody><body><freejoint/><geom size='.1'/><site name='s' size='.2'/></body>"
        "<body pos='1 0 0'><joint name='j' axis='0 0 1'/><geom size='.1'/></body></worldbody>"
        "<actuator><motor joint='j'/><general joint='j' dyntype='integrator'/></actuator>"
        f"<sensor><touch site='s'/><framepos objtype='site' objname='s'/></sensor><custom>{numerics}</custom></mujoco>"
    )


@cache
def layout() -> dict[str, int]:
    """Byte offsets of the fields the callback reads: nnumeric, numeric_adr, numeric_data (mjModel) and the
    _DATA_POINTERS (mjData)."""
    models = [_probe_model(n) for n in (3, 11, 29)]
    data = [mujoco.MjData(m) for m in models]
    offsets = _pointer_offsets(models, _MODEL_POINTERS)
    sizes = [_raw(m._address, 4096).view(np.int32) for m in models]
    hits = [i for i in range(len(sizes[0])) if all(s[i] == m.nnumeric for s, m in zip(sizes, models))]
    if len(hits) != 1:
        raise LayoutError(f"mujoco {mujoco.__version__}: cannot locate field nnumeric of the C struct")
    offsets["nnumeric"] = 4 * hits[0]
    data_offsets = _pointer_offsets(data, _DATA_POINTERS)
    return {**offsets, **data_offsets}


def _mujoco_library() -> ctypes.CDLL:
    folder = os.path.dirname(mujoco.__file__)
    name = next(f for f in sorted(os.listdir(folder)) if f.startswith("libmujoco.so") or f.startswith("libmujoco."))
    return ctypes.CDLL(os.path.join(folder, name))


def _cache_folder() -> Path:
    """Where the kernels' generated copies (and numba's cache of them) live."""
    root = os.environ.get("RACECAR_SIM_CACHE") or os.path.join(os.path.expanduser("~"), ".cache", "racecar_sim")
    return Path(root) / "kernels"


@cache
def kernels() -> ModuleType:
    """tyre_kernels.py with this MuJoCo's struct offsets filled in, imported from a copy in the cache folder (named
    by a hash of the offsets, MuJoCo's version and the template), so numba compiles its cfuncs once per machine."""
    template = (Path(__file__).parent / "tyre_kernels.py").read_text()
    offsets = layout()
    source = template.replace("OFFSETS: dict[str, int] = {}", f"OFFSETS: dict[str, int] = {offsets!r}", 1)
    import hashlib  # here: a run without tyres does not load it

    digest = hashlib.sha1(f"{mujoco.__version__}\n{source}".encode()).hexdigest()[:16]
    folder = _cache_folder()
    path = folder / f"racecar_tyre_kernels_{digest}.py"
    try:
        folder.mkdir(parents=True, exist_ok=True)
        if not path.exists():
            scratch = path.with_suffix(f".{os.getpid()}.tmp")
            scratch.write_text(source)
            scratch.replace(path)  # atomic: processes starting together see the whole file or none
    except OSError:  # a read-only home: a private folder, compiled in this process only
        path = Path(tempfile.mkdtemp(prefix="racecar_sim_kernels_")) / path.name
        path.write_text(source)
    spec = importlib.util.spec_from_file_location(path.stem, path)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[path.stem] = module  # numba's cache finds the module by name
    spec.loader.exec_module(module)
    assert (module.MAGIC, module.HEADER, module.STRIDE, module.DYNPRM_SIZE) == (MAGIC, HEADER, STRIDE, DYNPRM_SIZE)
    return module


def apply_ft_address() -> int:
    """The address of MuJoCo's mj_applyFT in this process (the tyre table carries it to the kernel)."""
    return ctypes.cast(_mujoco_library().mj_applyFT, ctypes.c_void_p).value or 0


def install() -> None:
    """Make the compiled callback MuJoCo's mjcb_passive (once per process; it adds nothing to models without tyres).
    A passive callback of someone else's is an error rather than silently replaced."""
    compiled = kernels().tyres
    current = mujoco.get_mjcb_passive()
    if current is compiled.ctypes:
        return
    if current is not None:
        raise RuntimeError("tyres: MuJoCo's mjcb_passive is set already by other code; the tyre model needs it")
    mujoco.set_mjcb_passive(compiled.ctypes)


def install_actuator_dynamics() -> None:
    """Make the rate limit MuJoCo's mjcb_act_dyn (once per process; called only for `user` dyntype actuators)."""
    compiled = kernels().rate_limited
    current = mujoco.get_mjcb_act_dyn()
    if current is compiled.ctypes:
        return
    if current is not None:
        raise RuntimeError("actuation: MuJoCo's mjcb_act_dyn is set already by other code; the rate limits need it")
    mujoco.set_mjcb_act_dyn(compiled.ctypes)
