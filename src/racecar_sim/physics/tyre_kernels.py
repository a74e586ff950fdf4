"""The compiled kernels of the tyre model and the actuator limits (physics/tyre_callback.py explains them).

This file is a template: tyre_callback.kernels() writes a copy of it with OFFSETS filled in (the C struct layout it
measured for this MuJoCo) to a cache folder and imports that copy, whose numba cfuncs are cached on disk, so a
process compiles them once per machine and MuJoCo version rather than at every start. This module itself, with no
OFFSETS, compiles nothing.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numba import carray, cfunc, njit, types
from numba.extending import intrinsic

OFFSETS: dict[str, int] = {}  # filled in the generated copy
MAGIC = 7_311_993.0  # first value of a tyre table
HEADER = 3  # MAGIC, number of wheels, the address of mj_applyFT
STRIDE = 20  # values per wheel
LINEAR, PACEJKA = 1.0, 2.0
DYNPRM_SIZE = 10  # mjNDYN

OFF_NNUMERIC = OFFSETS.get("nnumeric", 0)
OFF_NUMERIC_ADR, OFF_NUMERIC_DATA = OFFSETS.get("numeric_adr", 0), OFFSETS.get("numeric_data", 0)
OFF_ACTADR, OFF_DYNPRM = OFFSETS.get("actuator_actadr", 0), OFFSETS.get("actuator_dynprm", 0)
OFF_XPOS, OFF_XMAT, OFF_CVEL = OFFSETS.get("xpos", 0), OFFSETS.get("xmat", 0), OFFSETS.get("cvel", 0)
OFF_COM, OFF_SENSOR, OFF_QFRC = (
    OFFSETS.get("subtree_com", 0),
    OFFSETS.get("sensordata", 0),
    OFFSETS.get("qfrc_passive", 0),
)
OFF_CTRL, OFF_ACT = OFFSETS.get("ctrl", 0), OFFSETS.get("act", 0)


def _load_word(typingctx: Any, base: Any, offset: Any) -> Any:
    """The 8 bytes at base + offset, as an integer (a pointer field)."""
    sig = types.intp(types.voidptr, types.intp)

    def codegen(context: Any, builder: Any, signature: Any, args: Any) -> Any:
        address = builder.gep(args[0], [args[1]])
        word = context.get_value_type(types.intp)
        return builder.load(builder.bitcast(address, word.as_pointer()))

    return sig, codegen


load_word: Any = intrinsic(_load_word)  # typed by numba, not by mypy


def _load_int(typingctx: Any, base: Any, offset: Any) -> Any:
    """The 4 bytes at base + offset, as an int32 (a size field)."""
    sig = types.int32(types.voidptr, types.intp)

    def codegen(context: Any, builder: Any, signature: Any, args: Any) -> Any:
        address = builder.gep(args[0], [args[1]])
        word = context.get_value_type(types.int32)
        return builder.load(builder.bitcast(address, word.as_pointer()))

    return sig, codegen


load_int: Any = intrinsic(_load_int)  # typed by numba, not by mypy


def _pointer_to(element: Any) -> Any:
    """A numba intrinsic taking an integer address to an `element`* (float64: double*, int32: int*)."""

    def cast(typingctx: Any, address: Any) -> Any:
        sig = types.CPointer(element)(types.intp)

        def codegen(context: Any, builder: Any, signature: Any, args: Any) -> Any:
            return builder.inttoptr(args[0], context.get_value_type(signature.return_type))

        return sig, codegen

    return intrinsic(cast)


doubles: Any = _pointer_to(types.float64)  # an integer address as a double*; typed by numba, not by mypy
ints: Any = _pointer_to(types.int32)  # an integer address as an int*


def _apply_ft(
    typingctx: Any, function: Any, m: Any, d: Any, force: Any, torque: Any, point: Any, body: Any, target: Any
) -> Any:
    """mj_applyFT(m, d, force, torque, point, body, qfrc_target) through its address (an integer, from the tyre
    table: a process-specific address kept out of the compiled code, so that it can be cached)."""
    sig = types.void(
        types.intp, types.voidptr, types.voidptr, types.intp, types.intp, types.intp, types.intp, types.intp
    )

    def codegen(context: Any, builder: Any, signature: Any, args: Any) -> None:
        from llvmlite import ir

        double_ptr = ir.DoubleType().as_pointer()
        byte_ptr = ir.IntType(8).as_pointer()
        fnty = ir.FunctionType(
            ir.VoidType(), [byte_ptr, byte_ptr, double_ptr, double_ptr, double_ptr, ir.IntType(32), double_ptr]
        )
        fn = builder.inttoptr(args[0], fnty.as_pointer())
        force_, torque_, point_, target_ = (builder.inttoptr(args[i], double_ptr) for i in (3, 4, 5, 7))
        body_ = builder.trunc(args[6], ir.IntType(32))
        builder.call(fn, [args[1], args[2], force_, torque_, point_, body_, target_])

    return sig, codegen


apply_ft: Any = intrinsic(_apply_ft)  # typed by numba, not by mypy


@njit(inline="always")
def magic_formula(x: float, b: float, c: float, d: float, e: float) -> float:
    bx = b * x
    return d * math.sin(c * math.atan(bx - e * (bx - math.atan(bx))))


def _tyres(m: Any, d: Any) -> None:
    nnumeric: int = load_int(m, OFF_NNUMERIC)
    if nnumeric <= 0:
        return
    numeric_adr = ints(load_word(m, OFF_NUMERIC_ADR))
    numeric_data = doubles(load_word(m, OFF_NUMERIC_DATA))
    for k in range(nnumeric):
        table = carray(doubles(load_word(m, OFF_NUMERIC_DATA) + 8 * numeric_adr[k]), (HEADER,))
        if table[0] != MAGIC:
            continue
        wheels, apply_address = int(table[1]), int(table[2])
        start = numeric_adr[k] + HEADER
        xpos, xmat = doubles(load_word(d, OFF_XPOS)), doubles(load_word(d, OFF_XMAT))
        cvel, com = doubles(load_word(d, OFF_CVEL)), doubles(load_word(d, OFF_COM))
        sensordata = doubles(load_word(d, OFF_SENSOR))
        qfrc = load_word(d, OFF_QFRC)
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
            apply_ft(apply_address, m, d, base, base + 24, base + 48, body, qfrc)


def _rate_limited(m: Any, d: Any, i: int) -> float:
    ctrl = doubles(load_word(d, OFF_CTRL))[i]
    act = doubles(load_word(d, OFF_ACT))[ints(load_word(m, OFF_ACTADR))[i]]
    prm = doubles(load_word(m, OFF_DYNPRM))
    lo, hi, dt = prm[DYNPRM_SIZE * i], prm[DYNPRM_SIZE * i + 1], prm[DYNPRM_SIZE * i + 2]
    return min(max((ctrl - act) / dt, lo), hi)


if OFFSETS:  # the generated copy only
    tyres = cfunc(types.void(types.voidptr, types.voidptr), cache=True)(_tyres)
    rate_limited = cfunc(types.float64(types.voidptr, types.voidptr, types.int32), cache=True)(_rate_limited)
