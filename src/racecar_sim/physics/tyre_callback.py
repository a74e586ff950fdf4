"""The tyre forces as MuJoCo's passive-force callback, compiled (numba `cfunc`): no Python runs in the physics step.

MuJoCo calls `mjcb_passive(m, d)` at the end of its passive forces, in every step of every model of the process. The
callback looks for tyre tables among the model's custom numerics (a table starts with MAGIC; runtime fills it after
each compile); a model without one (every `seed` car, any other model) gets nothing added, bit for bit. Per wheel of
a table it reads, from the mjData: the wheel body's pose (xpos, xmat) and velocity (cvel about subtree_com), the
wheel's normal load (a touch sensor of the previous step's contact forces), and adds the tyre force at the contact
point with mj_applyFT to qfrc_passive.

The callback reaches mjModel and mjData fields through their C struct's layout. The bindings do not publish the
offsets; MuJoCo ships the structs' declarations (mujoco.introspect: field order and types), which ctypes lays out
as the C compiler does, and each offset is checked once per process on a probe model (a pointer field holds the
address of the array the bindings show, a size field the size). A layout that fails the check is an error naming
the field, never a guess.

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


# the C types of mjModel's and mjData's fields (mujoco.introspect's names) as ctypes; an enum is an int
_C_TYPES: dict[str, Any] = {
    "int": ctypes.c_int,
    "unsigned int": ctypes.c_uint,
    "float": ctypes.c_float,
    "double": ctypes.c_double,
    "char": ctypes.c_char,
    "mjtNum": ctypes.c_double,
    "mjtSize": ctypes.c_int64,
    "mjtBool": ctypes.c_ubyte,
    "mjtByte": ctypes.c_ubyte,
    "size_t": ctypes.c_size_t,
    "uintptr_t": ctypes.c_size_t,
    "uint64_t": ctypes.c_uint64,
    "int64_t": ctypes.c_int64,
}


def _c_type(declared: Any, where: str) -> Any:
    """The ctypes type of one declared field type (introspect's ValueType, PointerType, ArrayType or anonymous
    struct)."""
    kind = type(declared).__name__
    if kind == "PointerType":
        return ctypes.c_void_p
    if kind == "ArrayType":
        element = _c_type(declared.inner_type, where)
        for extent in reversed(declared.extents):
            element = element * int(extent)
        return element
    if kind == "AnonymousStructDecl":
        return _c_struct(declared.fields, where)
    name = str(getattr(declared, "name", ""))
    if name in _C_TYPES:
        return _C_TYPES[name]
    from mujoco.introspect import enums, structs

    if name in enums.ENUMS:
        return ctypes.c_int
    if name in structs.STRUCTS:
        return _c_struct(structs.STRUCTS[name].fields, name)
    raise LayoutError(f"mujoco {mujoco.__version__}: field of {where} has a C type {declared} the layout cannot size")


def _c_struct(fields: Any, where: str) -> Any:
    """A ctypes Structure with the declared fields in their order (C's alignment rules, as the compiler's)."""
    return type(where, (ctypes.Structure,), {"_fields_": [(f.name, _c_type(f.type, where)) for f in fields]})


def _probe_model(n: int) -> mujoco.MjModel:
    numerics = "".join(f"<numeric name='n{i:03d}' data='1 2 3 4 5 6 7'/>" for i in range(n))
    return mujoco.MjModel.from_xml_string(
        "<mujoco><worldbody><body><freejoint/><geom size='.1'/><site name='s' size='.2'/></body>"
        "<body pos='1 0 0'><joint name='j' axis='0 0 1'/><geom size='.1'/></body></worldbody>"
        "<actuator><motor joint='j'/><general joint='j' dyntype='integrator'/></actuator>"
        f"<sensor><touch site='s'/><framepos objtype='site' objname='s'/></sensor><custom>{numerics}</custom></mujoco>"
    )


def _word(address: int, size: int) -> int:
    return int.from_bytes(ctypes.string_at(address, size), sys.byteorder)


@cache
def layout() -> dict[str, int]:
    """Byte offsets of the fields the callback reads: nnumeric and the _MODEL_POINTERS (mjModel), the
    _DATA_POINTERS (mjData). They come from the struct declarations MuJoCo ships (mujoco.introspect), laid out by
    ctypes as the C compiler lays them out, and are checked on a probe model: each pointer field must hold the
    address of the array the bindings show, and nnumeric the count. A mismatch is an error naming the field, never
    a guess."""
    from mujoco.introspect import structs  # ~50 ms to import: only for a model with tyres or rate limits

    offsets: dict[str, int] = {}
    probe = _probe_model(3)
    data = mujoco.MjData(probe)
    for struct_name, live, pointers in (("mjModel", probe, _MODEL_POINTERS), ("mjData", data, _DATA_POINTERS)):
        c_struct = _c_struct(structs.STRUCTS[struct_name].fields, struct_name)
        for name in pointers:
            offsets[name] = getattr(c_struct, name).offset
            if _word(live._address + offsets[name], 8) != getattr(live, name).ctypes.data:
                raise LayoutError(
                    f"mujoco {mujoco.__version__}: field {name} of {struct_name} is not where its declaration puts it"
                )
        if struct_name == "mjModel":
            offsets["nnumeric"] = c_struct.nnumeric.offset
            if _word(live._address + offsets["nnumeric"], 4) != live.nnumeric:
                raise LayoutError(
                    f"mujoco {mujoco.__version__}: field nnumeric of mjModel is not where its declaration puts it"
                )
    return offsets


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
