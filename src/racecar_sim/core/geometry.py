"""Plane geometry shared by the world loader (mesh surfaces) and the world pictures (footprints)."""

from __future__ import annotations

import numpy as np
import numpy.typing as npt


def convex_hull(points: np.ndarray) -> np.ndarray:
    """Convex hull of 2-D points, counter-clockwise (Andrew's monotone chain); fewer than 3 points pass through."""
    pts: npt.NDArray[np.float64] = np.round(np.asarray(points, dtype=float).reshape(-1, 2), 9)
    pts = pts[np.lexsort((pts[:, 1], pts[:, 0]))]  # by x, then y; faster than np.unique(axis=0) on tiny arrays
    pts = pts[np.r_[True, np.any(np.diff(pts, axis=0) != 0, axis=1)][: len(pts)]]
    if len(pts) < 3:
        return pts
    rows = [tuple(p) for p in pts]

    def chain(seq: list[tuple[float, float]]) -> list[tuple[float, float]]:
        out: list[tuple[float, float]] = []
        for p in seq:
            while (
                len(out) >= 2
                and ((out[-1][0] - out[-2][0]) * (p[1] - out[-2][1]) - (out[-1][1] - out[-2][1]) * (p[0] - out[-2][0]))
                <= 0
            ):
                out.pop()
            out.append(p)
        return out

    return np.array(chain(rows)[:-1] + chain(rows[::-1])[:-1])
