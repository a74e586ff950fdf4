"""The frustum test and record compaction of culling.py, compiled (numba): a few microseconds a frame, where numpy's
dozen small operations took 45."""

from __future__ import annotations

import numpy as np
from numba import njit
from numpy.typing import NDArray


@njit(cache=True, nogil=True)
def cull_records(
    raw: NDArray[np.uint8],
    pos: NDArray[np.float32],
    rbound: NDArray[np.float32],
    kind: NDArray[np.int32],
    half: NDArray[np.float32],
    mat: NDArray[np.float32],
    boxed: NDArray[np.uint8],
    n: int,
    left_eye: NDArray[np.float32],
    right_eye: NDArray[np.float32],
    forward: NDArray[np.float32],
    up: NDArray[np.float32],
    near: float,
    center: float,
    bottom: float,
    top: float,
    aspect: float,
    margin: float,
    clearance: float,
) -> int:
    """Keep, in order, the records of the first n that may meet the frustum (its sides widened by `margin`, its near
    plane as it is), their extent widened by `clearance`; returns how many were kept. A geom's extent is its bounding
    sphere (pos, rbound), and also, where its type is `boxed` (culling._boxed_types), its box (pos, mat, half): a
    geom is left out when either lies wholly outside one plane. mjr_render draws a mono image from the average of
    both eyes."""
    eye = np.empty(3)
    side = np.empty(3)
    for k in range(3):
        eye[k] = 0.5 * (np.float64(left_eye[k]) + np.float64(right_eye[k]))
    side[0] = forward[1] * up[2] - forward[2] * up[1]
    side[1] = forward[2] * up[0] - forward[0] * up[2]
    side[2] = forward[0] * up[1] - forward[1] * up[0]
    half_height = 0.5 * (top - bottom)
    middle = 0.5 * (top + bottom)
    half_width = half_height * aspect
    x_lo, x_hi = center - margin * half_width, center + margin * half_width
    y_lo, y_hi = middle - margin * half_height, middle + margin * half_height
    # the planes' inward normals (side, up, forward components), unit, and their offsets: a point p of the camera's
    # frame is inside a plane where normal . p >= offset. The four sides pass through the eye; then the near plane.
    normals = np.array([[near, 0.0, -x_lo], [-near, 0.0, x_hi], [0.0, near, -y_lo], [0.0, -near, y_hi], [0, 0, 1.0]])
    offsets = np.array([0.0, 0.0, 0.0, 0.0, near])
    for p in range(4):
        length = np.sqrt(normals[p, 0] ** 2 + normals[p, 1] ** 2 + normals[p, 2] ** 2)
        for k in range(3):
            normals[p, k] /= length
    axes = np.empty((3, 3))  # a geom's box axes in the camera's frame: axes[j] = (side, up, forward) of axis j
    kept = 0
    for i in range(n):
        radius = np.float64(rbound[i])
        inside = True
        if radius > 0:  # 0: no bounding sphere (a plane, a decoration): always drawn
            dx, dy, dz = pos[i, 0] - eye[0], pos[i, 1] - eye[1], pos[i, 2] - eye[2]
            x = dx * side[0] + dy * side[1] + dz * side[2]
            y = dx * up[0] + dy * up[1] + dz * up[2]
            z = dx * forward[0] + dy * forward[1] + dz * forward[2]
            t = kind[i]
            box = 0 <= t < boxed.shape[0] and boxed[t] != 0
            if box:
                for j in range(3):  # column j of the row-major mat: the geom's axis j in the world
                    ax, ay, az = mat[i, j], mat[i, 3 + j], mat[i, 6 + j]
                    axes[j, 0] = ax * side[0] + ay * side[1] + az * side[2]
                    axes[j, 1] = ax * up[0] + ay * up[1] + az * up[2]
                    axes[j, 2] = ax * forward[0] + ay * forward[1] + az * forward[2]
            for p in range(5):
                nx, ny, nz = normals[p, 0], normals[p, 1], normals[p, 2]
                reach = radius  # how far the geom reaches along the normal from its centre
                if box:
                    extent = 0.0
                    for j in range(3):
                        extent += abs(np.float64(half[i, j])) * abs(nx * axes[j, 0] + ny * axes[j, 1] + nz * axes[j, 2])
                    reach = min(reach, extent)
                if nx * x + ny * y + nz * z - offsets[p] < -(reach + clearance):
                    inside = False
                    break
        if inside:
            if kept != i:
                raw[kept, :] = raw[i, :]
            kept += 1
    return kept
