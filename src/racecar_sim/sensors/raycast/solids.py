"""Beams against moving solids (other cars' boxes and wheels, pushable boxes), exactly, in compiled code.

A fleet's lidars see the other cars, whose geoms move every step and tilt with the car (pitch under braking, roll in
a turn): a box of another car is an upright prism only to within its tilt, and a wheel is a cylinder lying on its
side. Rather than cut them into footprints per scan, each beam near one is intersected with it in 3-D, here, with
MuJoCo's own formulas (engine_ray.c: ray_box, ray_cylinder, ray_sphere, ray_capsule, ray_ellipsoid, the same
operations in the same order), so a beam's range is mj_ray's range at any tilt. The beams tried are those whose
angle can meet the solid's bounding sphere (culled per solid by the scan's height band and by reach, then one
interval of beams per solid): a few dozen beam-solid pairs per other car in view, all inside the one compiled call
of a scan (laser_kernel.level_scan).

Solids are geoms of the primitive types below; anything else that moves (a mesh, a plane, a height field) is cast
by RayCaster's general path instead (see scene.Solids.of). Geom poses are read from an MjData posed at the live qpos
(sensors/shared_pose.py: once per tick for the whole fleet).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from llvmlite import ir
from numba import njit, types
from numba.core import cgutils
from numba.extending import intrinsic

from racecar_sim.sensors.raycast.kernels import (
    CREACH2,
    CROSS,
    CX,
    CY,
    EX,
    EY,
    MIDX,
    MIDY,
    REACH2,
    TWO_SIDED,
    WALL_ROWS,
    X0,
    X1,
    Y0,
    Y1,
    ZHI,
    ZLO,
    Beams,
    Floats,
    Indices,
    Plane,
    beam_range,
    walls_in_band,
)
from racecar_sim.sensors.raycast.scene import BOX, CAPSULE, CYLINDER, ELLIPSOID, SPHERE, VERTICAL_TOL

MINVAL = 1e-15  # MuJoCo's mjMINVAL
_CULL_SLACK = 1.0 + 1e-9  # kernels.wall_table's


@intrinsic
def fused_multiply_add(typingctx: Any, a: Any, b: Any, c: Any) -> tuple[Any, Any]:
    """a * b + c rounded once (llvm.fma.f64: the CPU's FMA instruction, or libm's exact fma where it has none)."""
    signature = types.float64(types.float64, types.float64, types.float64)

    def codegen(context: Any, builder: Any, sig: Any, args: Any) -> Any:
        double = ir.DoubleType()
        fma = cgutils.get_or_insert_function(builder.module, ir.FunctionType(double, [double] * 3), "llvm.fma.f64")
        return builder.call(fma, args)

    return signature, codegen


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _quad(a: float, b: float, c: float) -> tuple[float, float, float]:
    """ray_quad: (smallest non-negative root or -1, both roots) of a x^2 + 2 b x + c = 0 (-1, -1 if none real)."""
    det = b * b - a * c
    if det < 0 or a < MINVAL:
        return -1.0, -1.0, -1.0
    det = math.sqrt(det)
    x0 = (-b - det) / a
    x1 = (-b + det) / a
    if x0 >= 0:
        return x0, x0, x1
    if x1 >= 0:
        return x1, x0, x1
    return -1.0, x0, x1


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _sphere(
    cx: float, cy: float, cz: float, dist_sqr: float, px: float, py: float, pz: float, vx: float, vy: float, vz: float
) -> float:
    """ray_sphere: distance along (vx, vy, vz) from p to the sphere around c of squared radius dist_sqr, or -1."""
    d0, d1, d2 = px - cx, py - cy, pz - cz
    a = vx * vx + vy * vy + vz * vz
    b = vx * d0 + vy * d1 + vz * d2
    c = d0 * d0 + d1 * d1 + d2 * d2 - dist_sqr
    return _quad(a, b, c)[0]


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _side(l0: float, l1: float, l2: float, w0: float, w1: float, w2: float, s0: float, s1: float, x: float) -> float:
    """The nearer of x (-1: none) and the hit on the side of a cylinder of radius s0 and half-length s1 about the z
    axis, of the ray from l along w (geom frame)."""
    a = w0 * w0 + w1 * w1
    b = w0 * l0 + w1 * l1
    c = l0 * l0 + l1 * l1 - s0 * s0
    sol = _quad(a, b, c)[0]
    if sol >= 0 and abs(l2 + sol * w2) <= s1:
        if x < 0 or sol < x:
            x = sol
    return x


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _cap(
    l0: float, l1: float, l2: float, w0: float, w1: float, w2: float, s0: float, s1: float, top: bool, x: float
) -> float:
    """The nearer of x (-1: none) and the hits on a capsule's top (or bottom) cap: the half of the sphere of radius s0
    around (0, 0, s1) (or -s1) beyond the side."""
    q2 = l2 - s1 if top else l2 + s1
    a = w0 * w0 + w1 * w1 + w2 * w2
    b = w0 * l0 + w1 * l1 + w2 * q2
    c = l0 * l0 + l1 * l1 + q2 * q2 - s0 * s0
    _, r0, r1 = _quad(a, b, c)
    for r in (r0, r1):
        if r >= 0 and (l2 + r * w2 >= s1 if top else l2 + r * w2 <= -s1):
            if x < 0 or r < x:
                x = r
    return x


@njit(cache=True, nogil=True, error_model="numpy")
def ray_solid(
    kind: int, pos: Floats, mat: Floats, size: Floats, px: float, py: float, pz: float, vx: float, vy: float, vz: float
) -> float:
    """mju_rayGeom for the primitive types: distance x >= 0 along v from p to the geom's surface, or -1."""
    s0, s1, s2 = size[0], size[1], size[2]
    if kind == SPHERE:
        return _sphere(pos[0], pos[1], pos[2], s0 * s0, px, py, pz, vx, vy, vz)
    if kind == BOX:
        if _sphere(pos[0], pos[1], pos[2], s0 * s0 + s1 * s1 + s2 * s2, px, py, pz, vx, vy, vz) < 0:
            return -1.0
    elif kind == CYLINDER:
        if _sphere(pos[0], pos[1], pos[2], s0 * s0 + s1 * s1, px, py, pz, vx, vy, vz) < 0:
            return -1.0
    elif kind == CAPSULE:
        ssz = s0 + s1
        if _sphere(pos[0], pos[1], pos[2], ssz * ssz, px, py, pz, vx, vy, vz) < 0:
            return -1.0
    # ray_map: the ray in the geom's frame
    d0, d1, d2 = px - pos[0], py - pos[1], pz - pos[2]
    l0 = mat[0] * d0 + mat[3] * d1 + mat[6] * d2
    l1 = mat[1] * d0 + mat[4] * d1 + mat[7] * d2
    l2 = mat[2] * d0 + mat[5] * d1 + mat[8] * d2
    w0 = mat[0] * vx + mat[3] * vy + mat[6] * vz
    w1 = mat[1] * vx + mat[4] * vy + mat[7] * vz
    w2 = mat[2] * vx + mat[5] * vy + mat[8] * vz
    x = -1.0
    if kind == BOX:
        lp = (l0, l1, l2)
        lv = (w0, w1, w2)
        sz = (s0, s1, s2)
        for i in range(3):
            if abs(lv[i]) > MINVAL:
                j, k = (1, 2) if i == 0 else ((0, 2) if i == 1 else (0, 1))
                for side in (-1.0, 1.0):
                    sol = (side * sz[i] - lp[i]) / lv[i]
                    if sol >= 0:
                        p0 = lp[j] + sol * lv[j]
                        p1 = lp[k] + sol * lv[k]
                        if abs(p0) <= sz[j] and abs(p1) <= sz[k]:
                            if x < 0 or sol < x:
                                x = sol
        return x
    if kind == CYLINDER:
        if abs(w2) > MINVAL:
            for side in (-1.0, 1.0):
                sol = (side * s1 - l2) / w2
                if sol >= 0:
                    p0 = l0 + sol * w0
                    p1 = l1 + sol * w1
                    if p0 * p0 + p1 * p1 <= s0 * s0:
                        if x < 0 or sol < x:
                            x = sol
        return _side(l0, l1, l2, w0, w1, w2, s0, s1, x)
    if kind == CAPSULE:
        x = _side(l0, l1, l2, w0, w1, w2, s0, s1, x)
        x = _cap(l0, l1, l2, w0, w1, w2, s0, s1, True, x)
        return _cap(l0, l1, l2, w0, w1, w2, s0, s1, False, x)
    # ellipsoid
    i0, i1, i2 = 1 / (s0 * s0), 1 / (s1 * s1), 1 / (s2 * s2)
    a = i0 * w0 * w0 + i1 * w1 * w1 + i2 * w2 * w2
    b = i0 * w0 * l0 + i1 * w1 * l1 + i2 * w2 * l2
    c = i0 * l0 * l0 + i1 * l1 * l1 + i2 * l2 * l2 - 1
    return _quad(a, b, c)[0]


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _half_height(kind: int, mat: Floats, size: Floats) -> float:
    """Half the world z-extent of a geom with rotation `mat` (row-major 3x3, flat) and `size`."""
    s0, s1, s2 = size[0], size[1], size[2]
    m6, m7, m8 = mat[6], mat[7], mat[8]  # world z of the geom's axes
    if kind == BOX:
        return abs(m6) * s0 + abs(m7) * s1 + abs(m8) * s2
    if kind == CYLINDER:
        return abs(m8) * s1 + s0 * math.sqrt(max(1.0 - m8 * m8, 0.0))
    if kind == CAPSULE:
        return abs(m8) * s1 + s0
    if kind == ELLIPSOID:
        return math.sqrt((m6 * s0) ** 2 + (m7 * s1) ** 2 + (m8 * s2) ** 2)
    return s0  # sphere


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _upright_axis(mat: Floats) -> int:
    """scene._vertical_axis: the first axis of the geom standing vertical within VERTICAL_TOL, or -1."""
    for axis in range(3):
        if abs(mat[axis]) <= VERTICAL_TOL and abs(mat[3 + axis]) <= VERTICAL_TOL:
            return axis
    return -1


@njit(cache=True, nogil=True, error_model="numpy")
def _footprint(
    pos: Floats, mat: Floats, size: Floats, k: int, range_min: float, range_max: float, table: Floats
) -> tuple[float, float, float]:
    """The footprint of a box standing on its axis k as four one-sided walls (kernels.wall_table rows, into
    `table`; scene.box_footprint's corners to the bit), and its circle (cx, cy, radius)."""
    i, j = (1, 2) if k == 0 else ((0, 2) if k == 1 else (0, 1))
    ax, ay = mat[i] * size[i], mat[3 + i] * size[i]
    bx, by = mat[j] * size[j], mat[3 + j] * size[j]
    xs = (pos[0] + (ax + bx), pos[0] + (-ax + bx), pos[0] + (-ax - bx), pos[0] + (ax - bx))
    ys = (pos[1] + (ay + by), pos[1] + (-ay + by), pos[1] + (-ay - by), pos[1] + (ay - by))
    if xs[0] * ys[1] + xs[1] * ys[2] + xs[2] * ys[3] + xs[3] * ys[0] < (
        ys[0] * xs[1] + ys[1] * xs[2] + ys[2] * xs[3] + ys[3] * xs[0]
    ):  # wind counter-clockwise
        xs, ys = (xs[3], xs[2], xs[1], xs[0]), (ys[3], ys[2], ys[1], ys[0])
    cx = 0.5 * (min(xs) + max(xs))
    cy = 0.5 * (min(ys) + max(ys))
    radius = 0.0
    for c in range(4):
        radius = max(radius, math.hypot(xs[c] - cx, ys[c] - cy))
    for w in range(4):
        x0, y0, x1, y1 = xs[w], ys[w], xs[(w + 1) % 4], ys[(w + 1) % 4]
        half = 0.5 * math.hypot(x1 - x0, y1 - y0)
        table[X0, w], table[Y0, w], table[X1, w], table[Y1, w] = x0, y0, x1, y1
        table[ZLO, w], table[ZHI, w] = pos[2] - size[k], pos[2] + size[k]
        table[MIDX, w], table[MIDY, w] = 0.5 * (x0 + x1), 0.5 * (y0 + y1)
        table[REACH2, w] = ((half + range_max) * _CULL_SLACK) ** 2
        table[CX, w], table[CY, w] = cx, cy
        table[CREACH2, w] = ((radius + range_min) * _CULL_SLACK) ** 2
        table[CROSS, w] = x0 * y1 - y0 * x1
        table[EX, w], table[EY, w] = x1 - x0, y1 - y0
        table[TWO_SIDED, w] = 0.0
    return cx, cy, radius


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _circle_span(
    cx: float, cy: float, radius: float, ox: float, oy: float, plane: Plane, stretch: float, beams: Beams
) -> tuple[float, float]:
    """planar.circle_intervals for one circle (cx, cy, radius) seen from (ox, oy): its fan positions (lo, hi), hi
    possibly past a full turn (every beam when it holds the origin). Its radius is stretched by the plane map's
    largest singular value `stretch`, and grown."""
    angle_min, inverse_step, count, _ = beams
    p00, p01, p10, p11 = plane
    tx, ty = cx - ox, cy - oy
    qx, qy = p00 * tx + p01 * ty, p10 * tx + p11 * ty
    r = radius * stretch * (1.0 + 1e-9) + 1e-12
    distance = math.hypot(qx, qy)
    if distance <= r:
        return 0.0, count - 1.0
    half = math.asin(min(r / distance, 1.0))
    start = math.atan2(qy, qx) - half - angle_min
    start = start - math.floor(start / (2.0 * math.pi)) * (2.0 * math.pi)  # np.mod into [0, 2 pi)
    lo = start * inverse_step
    return lo, lo + 2.0 * half * inverse_step


@njit(cache=True, nogil=True, error_model="numpy")
def cast_solids(
    xpos: Floats,
    xmat: Floats,
    ids: Indices,
    types: Indices,
    sizes: Floats,
    rbound: Floats,
    origin: Floats,
    rotation: Floats,
    plane: Plane,
    stretch: float,
    lo: float,
    hi: float,
    beams: Beams,
    range_min: float,
    range_max: float,
    dirs: Floats,
    ranges: Floats,
) -> int:
    """Lower `ranges` to each beam's first hit on the solids (geoms `ids` at the poses xpos (ngeom, 3), xmat (ngeom,
    9)) at or beyond range_min, as RayCaster.cast finds it. The scan: `origin`, its axes `rotation` (world from
    sensor), the plane map (ScanFrame.to_plane) and its largest singular value `stretch`, the band [lo, hi].

    RayCaster.cast's rule, beam for beam: a box standing upright (scene.VERTICAL_TOL) across the band is cast as the
    walls are, through its footprint's edges; every other solid is cast in 3-D with MuJoCo's formulas (ray_solid,
    a hit nearer than range_min looked past from range_min along the beam, as MujocoRays does), and so is every
    solid on the beams that may meet one of those (RayCaster's unsure beams: the bounding circle of a solid that is
    not an upright prism, the footprint circle of one covering part of the band). Ranges past range_max are left
    for the caller to clear. Returns the number of beam-solid pairs cast in 3-D."""
    ox, oy, oz = origin[0], origin[1], origin[2]
    _, _, count, turn = beams
    n = ids.shape[0]
    mode = np.zeros(n, np.int8)  # 0: out of reach or band, 1: upright box across the band, 2: 3-D
    unsure = np.zeros(count, np.bool_)
    flat = np.full(count, np.inf)  # the upright boxes' hits, cast as walls
    table = np.empty((WALL_ROWS, 4))
    for s in range(n):  # what RayCaster.cast makes of each: footprint edges, footprint circle or bounding cylinder
        g, kind = ids[s], types[s]
        pos, mat, size = xpos[g], xmat[g], sizes[s]
        reach = math.hypot(pos[0] - ox, pos[1] - oy)
        if reach > rbound[s] + range_max or pos[2] - rbound[s] > hi or pos[2] + rbound[s] < lo:
            continue  # out of reach, or its bounding sphere above or below every beam
        k = _upright_axis(mat)
        mark_x, mark_y, mark_r = 0.0, 0.0, -1.0  # a circle whose beams are unsure (none: radius < 0)
        if kind == BOX and k >= 0:
            zlo, zhi = pos[2] - size[k], pos[2] + size[k]
            cx, cy, radius = _footprint(pos, mat, size, k, range_min, range_max, table)
            if zlo <= lo and zhi >= hi:
                mode[s] = 1
                walls_in_band(table, ox, oy, oz, plane, (0.0, 0.0), lo, hi, False, beams, range_min, dirs, flat)
            elif zlo < hi and zhi > lo:
                mode[s] = 2
                if math.hypot(cx - ox, cy - oy) <= radius + range_max:
                    mark_x, mark_y, mark_r = cx, cy, radius
        elif kind == CYLINDER and k == 2:
            zlo, zhi = pos[2] - size[1], pos[2] + size[1]
            if zlo < hi and zhi > lo:
                mode[s] = 2
                if not (zlo <= lo and zhi >= hi) and reach <= size[0] + range_max:
                    mark_x, mark_y, mark_r = pos[0], pos[1], size[0]
        else:  # a bounding cylinder: its beams are cast in 3-D
            mark_x, mark_y, mark_r = pos[0], pos[1], rbound[s]
            half = _half_height(kind, mat, size) * (1.0 + 1e-9) + 1e-12
            if pos[2] - half <= hi and pos[2] + half >= lo:  # else no beam reaches the solid itself
                mode[s] = 2
        if mark_r >= 0.0:  # the beams that may meet this circle are unsure: every solid on them is cast in 3-D
            start, end = _circle_span(mark_x, mark_y, mark_r, ox, oy, plane, stretch, beams)
            for part in range(2):
                first, last = beam_range(start, end, count, turn, part)
                unsure[first : last + 1] = True
    r00, r01, r10, r11, r20, r21 = (
        rotation[0, 0],
        rotation[0, 1],
        rotation[1, 0],
        rotation[1, 1],
        rotation[2, 0],
        rotation[2, 1],
    )
    tried = 0
    for s in range(n):
        if mode[s] == 0:
            continue
        g, kind = ids[s], types[s]
        pos, mat, size = xpos[g], xmat[g], sizes[s]
        start, end = _circle_span(pos[0], pos[1], rbound[s], ox, oy, plane, stretch, beams)
        for part in range(2):
            first, last = beam_range(start, end, count, turn, part)
            for b in range(first, last + 1):
                if mode[s] == 1 and not unsure[b]:
                    continue  # cast as walls are
                tried += 1
                # the beam's world direction as MujocoRays computes it (numpy's matmul of the axes and the fan's
                # directions: OpenBLAS fuses the second product onto the first), so that ranges agree to the bit
                c, sn = dirs[0, b], dirs[1, b]
                vx: float = fused_multiply_add(r01, sn, r00 * c)  # type: ignore[call-arg]
                vy: float = fused_multiply_add(r11, sn, r10 * c)
                vz: float = fused_multiply_add(r21, sn, r20 * c)
                x = ray_solid(kind, pos, mat, size, ox, oy, oz, vx, vy, vz)
                if 0.0 <= x < range_min:  # within range_min: look past it, from range_min along the beam
                    x = ray_solid(
                        kind, pos, mat, size, ox + range_min * vx, oy + range_min * vy, oz + range_min * vz, vx, vy, vz
                    )
                    x = range_min + x if x >= 0.0 else -1.0
                if x >= 0.0 and x < ranges[b]:
                    ranges[b] = x
    for b in range(count):
        if not unsure[b] and flat[b] < ranges[b]:
            ranges[b] = flat[b]
    return tried
