"""The world's bounding-volume tree refit after near-wall slots moved (near_walls._WorldTree), compiled: numpy's
per-level passes cost ~100 us a refit, this loop ~1 us."""

from __future__ import annotations

from numba import njit


@njit(cache=True, nogil=True)
def refit(aabb, inner, children):
    """Set each node of `inner` (children before parents) to the union of its two `children` rows; rows of
    `aabb` are centre (3) and half sizes (3)."""
    for k in range(len(inner)):
        node, a, b = inner[k], children[k, 0], children[k, 1]
        for i in range(3):
            low = min(aabb[a, i] - aabb[a, 3 + i], aabb[b, i] - aabb[b, 3 + i])
            high = max(aabb[a, i] + aabb[a, 3 + i], aabb[b, i] + aabb[b, 3 + i])
            aabb[node, i] = 0.5 * (low + high)
            aabb[node, 3 + i] = 0.5 * (high - low)
