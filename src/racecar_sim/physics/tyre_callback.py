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
import math
import os
from functools import cache
from typing import Any

import mujoco
import numpy as np

MAGIC = 7_311_993.0  # first value of a tyre table
HEADER = 2  # MAGIC, number of wheels
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


@cache
def _intrinsics() -> tuple[Any, Any, Any, Any]:
    """numba intrinsics reading C structs: load_word(base, offset) (a pointer field as an integer),
    load_int(base, offset) (an int field), doubles(address) and ints(address) (an integer address as double* / int*)."""
    from numba import types  # numba loads in ~0.3 s: only when a vehicle needs it
    from numba.extending import intrinsic

    @intrinsic
    def load_word(typingctx: Any, base: Any, offset: Any) -> Any:
        """The 8 bytes at base + offset, as an integer (a pointer field)."""
        sig = types.intp(types.voidptr, types.intp)

        def codegen(context: Any, builder: Any, signature: Any, args: Any) -> Any:
            address = builder.gep(args[0], [args[1]])
            word = context.get_value_type(types.intp)
            return builder.load(builder.bitcast(address, word.as_pointer()))

        return sig, codegen

    @intrinsic
    def load_int(typingctx: Any, base: Any, offset: Any) -> Any:
        """The 4 bytes at base + offset, as an int32 (a size field)."""
        sig = types.int32(types.voidptr, types.intp)

        def codegen(context: Any, builder: Any, signature: Any, args: Any) -> Any:
            address = builder.gep(args[0], [args[1]])
            word = context.get_value_type(types.int32)
            return builder.load(builder.bitcast(address, word.as_pointer()))

        return sig, codegen

    @intrinsic
    def doubles(typingctx: Any, address: Any) -> Any:
        """An integer address as a double*."""
        sig = types.CPointer(types.float64)(types.intp)

        def codegen(context: Any, builder: Any, signature: Any, args: Any) -> Any:
            return builder.inttoptr(args[0], context.get_value_type(signature.return_type))

        return sig, codegen

    @intrinsic
    def ints(typingctx: Any, address: Any) -> Any:
        """An integer address as an int*."""
        sig = types.CPointer(types.int32)(types.intp)

        def codegen(context: Any, builder: Any, signature: Any, args: Any) -> Any:
            return builder.inttoptr(args[0], context.get_value_type(signature.return_type))

        return sig, codegen

    return load_word, load_int, doubles, ints


@cache
def callback() -> Any:
    """The compiled tyre callback (numba cfunc), built once per process."""
    from numba import carray, cfunc, njit, types

    load_word, load_int, doubles, ints = _intrinsics()
    offsets = layout()
    apply_ft = _mujoco_library().mj_applyFT
    # pointers passed as integers: the same registers on every 64-bit ABI MuJoCo ships for
    apply_ft.argtypes = [ctypes.c_void_p, ctypes.c_void_p] + [ctypes.c_size_t] * 3 + [ctypes.c_int, ctypes.c_size_t]
    apply_ft.restype = None

    off_nnumeric, off_numeric_adr, off_numeric_data = (
        offsets["nnumeric"],
        offsets["numeric_adr"],
        offsets["numeric_data"],
    )
    off_xpos, off_xmat, off_cvel = offsets["xpos"], offsets["xmat"], offsets["cvel"]
    off_com, off_sensor, off_qfrc = offsets["subtree_com"], offsets["sensordata"], offsets["qfrc_passive"]

    @njit(inline="always")
    def magic_formula(x: float, b: float, c: float, d: float, e: float) -> float:
        bx = b * x
        return d * math.sin(c * math.atan(bx - e * (bx - math.atan(bx))))

    def tyres(m: Any, d: Any) -> None:
        nnumeric: int = load_int(m, off_nnumeric)
        if nnumeric <= 0:
            return
        numeric_adr = ints(load_word(m, off_numeric_adr))
        numeric_data = doubles(load_word(m, off_numeric_data))
        for k in range(nnumeric):
            table = carray(doubles(load_word(m, off_numeric_data) + 8 * numeric_adr[k]), (HEADER,))
            if table[0] != MAGIC:
                continue
            wheels = int(table[1])
            start = numeric_adr[k] + HEADER
            xpos, xmat = doubles(load_word(d, off_xpos)), doubles(load_word(d, off_xmat))
            cvel, com = doubles(load_word(d, off_cvel)), doubles(load_word(d, off_com))
            sensordata = doubles(load_word(d, off_sensor))
            qfrc = load_word(d, off_qfrc)
            buffer = np.zeros(9)
            for w in range(wheels):
                row = start + w * STRIDE
                body, root = int(numeric_data[row]), int(numeric_data[row + 1])
                load = sensordata[int(numeric_data[row + 2])]
                if load <= 0.0:
                    continue
                radius = numeric_data[row + 3]
                # spin axis in the world: xmat (row-major) times the axis in the body frame
                ax = ay = az = 0.0
                cx, cy, cz = xpos[3 * body], xpos[3 * body + 1], xpos[3 * body + 2]
                for j in range(3):
                    local = numeric_data[row + 4 + j]
                    ax += xmat[9 * body + j] * local
                    ay += xmat[9 * body + 3 + j] * local
                    az += xmat[9 * body + 6 + j] * local
                    offset = numeric_data[row + 16 + j]
                    cx += xmat[9 * body + j] * offset
                    cy += xmat[9 * body + 3 + j] * offset
                    cz += xmat[9 * body + 6 + j] * offset
                # heading across (e_y: the axis in the ground plane) and along (e_x = e_y x up)
                norm = math.sqrt(ax * ax + ay * ay)
                if norm < 1e-6:
                    continue  # the wheel lies flat
                yx, yy = ax / norm, ay / norm
                xx, xy = yy, -yx
                # contact point: the rim's lowest point, below the centre across the axis
                dx, dy, dz = -az * ax, -az * ay, 1.0 - az * az  # up minus its part along the axis
                dn = math.sqrt(dx * dx + dy * dy + dz * dz)
                px, py, pz = cx - radius * dx / dn, cy - radius * dy / dn, cz - radius * dz / dn
                # velocity of the centre and of the wheel's material at the contact point (cvel: about subtree_com)
                wx, wy, wz = cvel[6 * body], cvel[6 * body + 1], cvel[6 * body + 2]
                vx, vy = cvel[6 * body + 3], cvel[6 * body + 4]
                ox, oy, oz = com[3 * root], com[3 * root + 1], com[3 * root + 2]
                rx, ry, rz = cx - ox, cy - oy, cz - oz
                vcx, vcy = vx + wy * rz - wz * ry, vy + wz * rx - wx * rz
                rx, ry, rz = px - ox, py - oy, pz - oz
                vpx, vpy = vx + wy * rz - wz * ry, vy + wz * rx - wx * rz
                speed = abs(vcx * xx + vcy * xy)
                slip_x, slip_y = vpx * xx + vpy * xy, vpx * yx + vpy * yy
                rolling = abs(vcx * xx + vcy * xy - slip_x)  # the rim's speed, omega r
                kappa = -slip_x / max(speed, rolling, numeric_data[row + 14])
                alpha = math.atan(-slip_y / max(speed, numeric_data[row + 15]))
                mu = numeric_data[row + 8]
                if numeric_data[row + 7] == PACEJKA:
                    b, c, dd, e = (
                        numeric_data[row + 10],
                        numeric_data[row + 11],
                        numeric_data[row + 12],
                        numeric_data[row + 13],
                    )
                    fx = load * magic_formula(kappa, b, c, dd, e)
                    fy = load * magic_formula(alpha, b, c, dd, e)
                    peak = load * dd
                else:
                    stiffness = mu * numeric_data[row + 9] * load
                    fx, fy = stiffness * kappa, stiffness * alpha
                    peak = mu * load
                # the wheel's spin is integrated explicitly: no stiffer than its inertia allows in one step
                if abs(fx) > numeric_data[row + 19] * abs(slip_x):
                    fx = -numeric_data[row + 19] * slip_x
                total = math.sqrt(fx * fx + fy * fy)
                if total > peak:
                    fx, fy = fx * peak / total, fy * peak / total
                buffer[0] = fx * xx + fy * yx
                buffer[1] = fx * xy + fy * yy
                buffer[2] = 0.0
                buffer[3] = buffer[4] = buffer[5] = 0.0
                buffer[6], buffer[7], buffer[8] = px, py, pz
                base = buffer.ctypes.data
                apply_ft(m, d, base, base + 24, base + 48, body, qfrc)

    return cfunc(types.void(types.voidptr, types.voidptr))(tyres)


def install() -> None:
    """Make the compiled callback MuJoCo's mjcb_passive (once per process; it adds nothing to models without tyres).
    A passive callback of someone else's is an error rather than silently replaced."""
    compiled = callback()
    current = mujoco.get_mjcb_passive()
    if current is compiled.ctypes:
        return
    if current is not None:
        raise RuntimeError("tyres: MuJoCo's mjcb_passive is set already by other code; the tyre model needs it")
    mujoco.set_mjcb_passive(compiled.ctypes)


@cache
def actuator_dynamics() -> Any:
    """The compiled actuator dynamics (numba cfunc) of MuJoCo's `user` dyntype: the activation (the setpoint the
    servo follows) moves towards the control at a bounded rate, act_dot = clip((ctrl - act) / dt, lo, hi), with
    (lo, hi, dt) the actuator's dynprm[0:3]: a steering-rate limit (rad/s) on a hinge's angle setpoint, an
    acceleration limit (rad/s^2 of wheel rate) on a wheel-rate setpoint."""
    from numba import cfunc, types

    load_word, _, doubles, ints = _intrinsics()
    offsets = layout()
    off_ctrl, off_act = offsets["ctrl"], offsets["act"]
    off_actadr, off_dynprm = offsets["actuator_actadr"], offsets["actuator_dynprm"]
    ndyn = DYNPRM_SIZE

    def rate_limited(m: Any, d: Any, i: int) -> float:
        ctrl = doubles(load_word(d, off_ctrl))[i]
        act = doubles(load_word(d, off_act))[ints(load_word(m, off_actadr))[i]]
        prm = doubles(load_word(m, off_dynprm))
        lo, hi, dt = prm[ndyn * i], prm[ndyn * i + 1], prm[ndyn * i + 2]
        return min(max((ctrl - act) / dt, lo), hi)

    return cfunc(types.float64(types.voidptr, types.voidptr, types.int32))(rate_limited)


def install_actuator_dynamics() -> None:
    """Make the rate limit MuJoCo's mjcb_act_dyn (once per process; called only for `user` dyntype actuators)."""
    compiled = actuator_dynamics()
    current = mujoco.get_mjcb_act_dyn()
    if current is compiled.ctypes:
        return
    if current is not None:
        raise RuntimeError("actuation: MuJoCo's mjcb_act_dyn is set already by other code; the rate limits need it")
    mujoco.set_mjcb_act_dyn(compiled.ctypes)
