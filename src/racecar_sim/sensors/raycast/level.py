"""A level scan's wall cast in one compiled call: the common case of RayCaster.cast (and of laser_kernel.level_scan).

A scan that is not steep, has no floor in its height band and no wall within reach covering only part of that band is
answered by the walls alone, each a prism across the band: kernels.walls_in_band visits every wall of the cell, and
dense.cast_dense, on a dense_table, drops first the walls hidden behind nearer hits, with the same ranges to the bit.
"""

from __future__ import annotations

from numba import njit

from racecar_sim.sensors.raycast.dense import ZHI_MIN, ZLO_MAX, cast_dense
from racecar_sim.sensors.raycast.kernels import (
    WALL_ROWS,
    Floats,
    clear_past,
    level_band,
    partly_covered,
    plane_map,
    stretch_of,
    walls_in_band,
)


@njit(cache=True, nogil=True, error_model="numpy")
def cast_level(
    table: Floats,
    floors: Floats,
    origin: Floats,
    rotation: Floats,
    max_tilt_cos: float,
    angle_min: float,
    inverse_step: float,
    count: int,
    turn: float,
    range_min: float,
    range_max: float,
    dirs: Floats,
    ranges: Floats,
) -> bool:
    """Lowers `ranges` (count,) to the first hits on the walls of `table` (a kernels.wall_table, or a dense.dense_table:
    it has more rows), range_max applied, and returns True; or returns False, `ranges` untouched, when the scan
    needs the general path (a steep scan plane, a floor in the band, a wall within reach covering only part of the
    band). The frame is ScanFrame's, computed here."""
    level, lo, hi = level_band(floors, origin, rotation, max_tilt_cos, range_max)
    if not level:
        return False
    ox, oy, oz = origin[0], origin[1], origin[2]
    dense = table.shape[0] > WALL_ROWS
    # a dense table's lowest top and highest bottom of the columns from there on tell at once that no wall covers
    # part of the band
    settled = dense and table.shape[1] > 0 and table[ZLO_MAX, 0] <= lo and table[ZHI_MIN, 0] >= hi
    if not settled and partly_covered(table, ox, oy, lo, hi):
        return False
    plane, det = plane_map(rotation)
    beams = (angle_min, inverse_step, count, turn)
    if dense:
        cast_dense(table, ox, oy, oz, plane, stretch_of(plane, det), lo, hi, beams, range_min, dirs, ranges)
    else:
        walls_in_band(table, ox, oy, oz, plane, (0.0, 0.0), lo, hi, False, beams, range_min, dirs, ranges)
    clear_past(ranges, range_max)
    return True
