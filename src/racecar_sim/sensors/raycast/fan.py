"""A planar fan of beams, and the frame one scan casts it from.

The key fact the planar caster relies on: map the world's horizontal plane by the inverse of the 2x2
matrix A that projects the sensor's scan plane onto the horizontal plane. In the mapped plane the beams
are the fan's own unit directions (cos a, sin a), a vertical wall's footprint segment stays a segment,
and the distance along a beam to the mapped segment IS the 3-D distance along the tilted beam to the
wall. So a tilted scan of vertical prisms is exact, with no per-beam trigonometry.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

TWO_PI = 2.0 * math.pi
MAX_TILT_COS = 0.5  # a scan plane tilted more than 60 degrees is cast in 3-D only
INDEX_SLACK = 1e-9  # beams this close (in beam steps) to a footprint's edge are tested, not skipped


@dataclass(frozen=True)
class Fan:
    """`count` beams from `angle_min` in steps of `increment` (rad, about the sensor z axis), each seeing
    what lies between `range_min` and `range_max` (m) from the ray origin."""

    angle_min: float
    increment: float
    count: int
    range_min: float
    range_max: float
    directions: np.ndarray = field(init=False, repr=False, compare=False)  # (2, count): cos, sin
    inverse_step: float = field(init=False, repr=False, compare=False)  # beams per radian
    turn: float = field(init=False, repr=False, compare=False)  # beam steps in a full turn
    # the fan as the compiled casts take it: angle_min, inverse_step, count, turn, range_min, range_max, directions
    kernel_args: tuple[float, float, int, float, float, float, np.ndarray] = field(
        init=False, repr=False, compare=False
    )

    def __post_init__(self) -> None:
        angles = self.angle_min + self.increment * np.arange(self.count)
        object.__setattr__(self, "directions", np.array([np.cos(angles), np.sin(angles)]))
        step = self.increment if self.increment > 0 else 1.0  # a one-beam fan: any positive step works
        object.__setattr__(self, "inverse_step", 1.0 / step)
        object.__setattr__(self, "turn", TWO_PI / step)
        kernel_args = (self.angle_min, self.inverse_step, self.count, self.turn, self.range_min, self.range_max)
        object.__setattr__(self, "kernel_args", (*kernel_args, self.directions))


def plane_band(z: float, rotation: list[list[float]], range_max: float) -> tuple[float, float, float]:
    """The cos of a scan plane's tilt and the height band (lo, hi) its beams stay within up to `range_max`, for the ray
    origin at height `z` and the sensor axes `rotation` (rows; world from sensor): ScanFrame's level_cos and band."""
    (e1x, e2x, _), (e1y, e2y, _), (e1z, e2z, _) = rotation
    half = range_max * math.hypot(e1z, e2z) * (1.0 + 1e-12) + 1e-12
    return e1x * e2y - e2x * e1y, z - half, z + half  # the cos of the tilt: z of the scan plane's normal


class ScanFrame:
    """Where one scan is cast from: the ray origin and the sensor axes in the world, and what follows.

    `band` is the height range (lo, hi) every beam stays within up to range_max; `to_plane` (2x2, the
    inverse of the scan plane's horizontal projection) maps horizontal offsets into the plane where beams
    are the fan's unit directions; `stretch` is its largest singular value (1 for a level scan).
    """

    def __init__(self, origin: np.ndarray, rotation: np.ndarray, fan: Fan) -> None:
        self.origin = np.asarray(origin, dtype=float)
        self.rotation = np.asarray(rotation, dtype=float).reshape(3, 3)
        self.fan = fan
        rows = self.rotation.tolist()
        (e1x, e2x, _), (e1y, e2y, _), _ = rows
        self.level_cos, lo, hi = plane_band(float(self.origin[2]), rows, fan.range_max)
        self.band = (lo, hi)
        self.projection = np.array([[e1x, e2x], [e1y, e2y]])
        self.steep = self.level_cos < MAX_TILT_COS
        if self.steep:
            self.to_plane, self.stretch = np.eye(2), 1.0
            return
        det = self.level_cos
        self.to_plane = np.array([[e2y / det, -e2x / det], [-e1y / det, e1x / det]])
        squares = (e1x * e1x + e1y * e1y + e2x * e2x + e2y * e2y) / (det * det)
        inverse_det = 1.0 / det
        self.stretch = math.sqrt(0.5 * (squares + math.sqrt(max(squares * squares - 4.0 * inverse_det**2, 0.0))))

    def directions_3d(self, beams: np.ndarray | slice = slice(None)) -> np.ndarray:
        """World unit directions (n, 3) of the chosen beams."""
        u = self.fan.directions[:, beams]
        directions: np.ndarray = (self.rotation[:, :2] @ u).T
        return directions

    def horizontal_directions(self) -> np.ndarray:
        """Horizontal parts (2, count) of every beam's world direction (unit length for a level scan)."""
        horizontal: np.ndarray = self.projection @ self.fan.directions
        return horizontal
