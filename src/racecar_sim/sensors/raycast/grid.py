"""A uniform grid over the static footprints: each cell holds every item within range_max of any of its
points, copied into contiguous tables, so one dictionary look-up gives a scan all it may need.

An item that would be registered in more than LONG_CELLS cells (a wall kilometres long, the edge of a large ground
box, a huge bounding cylinder) is *long*: it is registered in no cell of its own, but joins the cells other items
made that lie within its reach, and the cell of every point no other item is near (`Grid.empty`). So the grid's
memory and build time grow with the number of items, never with their size; a scan sees the same items either way.
"""

from __future__ import annotations

import bisect
import math
from dataclasses import dataclass

import numpy as np

from racecar_sim.sensors.raycast.fan import Fan
from racecar_sim.sensors.raycast.planar import Walls
from racecar_sim.sensors.raycast.scene import Footprints


def split_by_band(
    segments: np.ndarray, circles: np.ndarray, lo: float, hi: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The segments and circles whose z-range covers the band [lo, hi], and the footprint circles
    (rows cx, cy, r) of those that cover only part of it (a beam may pass over, under or onto them)."""
    seg_lo, seg_hi, circ_lo, circ_hi = segments[4], segments[5], circles[3], circles[4]
    seg_covers = (seg_lo <= lo) & (seg_hi >= hi)
    circ_covers = (circ_lo <= lo) & (circ_hi >= hi)
    seg_partly = ~seg_covers & (seg_lo < hi) & (seg_hi > lo)
    circ_partly = ~circ_covers & (circ_lo < hi) & (circ_hi > lo)
    partly = np.concatenate([segments[9:12, seg_partly], circles[:3, circ_partly]], axis=1)
    return segments[:, seg_covers], circles[:, circ_covers], partly


class Cell:
    """The static items near one grid cell, and which of them cover a height band (cached per band)."""

    def __init__(
        self,
        segments: np.ndarray,
        circles: np.ndarray,
        bounds: np.ndarray,
        fan: Fan,
        centre: tuple[float, float] = (0.0, 0.0),
    ) -> None:
        # walls nearest the cell first: a scan from the cell then meets near walls before those they hide, which
        # the compiled cast skips beam by beam (any order gives the same ranges)
        order = np.argsort(np.hypot(segments[6] - centre[0], segments[7] - centre[1]), kind="stable")
        segments = segments[:, order]
        self.segments, self.circles, self.bounds, self.fan, self.centre = segments, circles, bounds, fan, centre
        self.breaks = sorted(set(np.concatenate([segments[4], segments[5], circles[3], circles[4]]).tolist()))
        self._covering: dict[int, tuple[Walls, np.ndarray]] = {}
        self._walls_only: np.ndarray | None = None

    def level_table(self) -> np.ndarray | None:
        """walls_only(), or an empty table (no walls at all) where the cell holds nothing; None where it holds
        circles or bounding cylinders."""
        if self.segments.shape[1]:
            return self.walls_only()
        if self.circles.shape[1] or self.bounds.shape[1]:
            return None
        from racecar_sim.sensors.raycast.kernels import WALL_ROWS

        return np.zeros((WALL_ROWS, 0))

    def walls_only(self) -> np.ndarray | None:
        """The kernels' table of this cell's walls if walls are all it holds (no circles, no bounding cylinders),
        for level.cast_level; else None."""
        if (
            self._walls_only is None
            and self.segments.shape[1]
            and not self.circles.shape[1]
            and not self.bounds.shape[1]
        ):
            from racecar_sim.sensors.raycast.kernels import wall_table

            self._walls_only = wall_table(self.segments, self.fan.range_min, self.fan.range_max)
        return self._walls_only

    def split(self, lo: float, hi: float) -> tuple[Walls, np.ndarray, np.ndarray]:
        """The walls and circles covering the band [lo, hi], and the footprint circles of those covering
        part of it (see split_by_band).

        Between two consecutive heights where some prism starts or ends, the covering set is the same for
        every band, so it is prepared once per such slab.
        """
        k = bisect.bisect_right(self.breaks, lo)
        if k < len(self.breaks) and self.breaks[k] < hi:  # a prism starts or ends inside the band
            segments, circles, partly = split_by_band(self.segments, self.circles, lo, hi)
            return Walls(segments, self.fan), circles, partly
        if k not in self._covering:
            segments, circles, _ = split_by_band(self.segments, self.circles, lo, hi)
            self._covering[k] = Walls(segments, self.fan), circles
        return (*self._covering[k], _NO_CIRCLES)


_NO_CIRCLES = np.zeros((3, 0))
LONG_CELLS = 256  # an item registered in more cells than this is long (a 230 m wall in 5 m cells; the tunnel's: 155)
FLAT_CELLS = 1 << 22  # FlatWalls' look-up table holds at most this many cells (32 MB); a sparser grid has none


def _merged(items: np.ndarray | None, long: np.ndarray | None) -> np.ndarray:
    """A cell's items and the long items near it, in the tables' order (as if all had been registered)."""
    if long is None:
        return items if items is not None else np.zeros(0, np.intp)
    return long if items is None else np.sort(np.concatenate([items, long]))


def _segment_distances(points: np.ndarray, ends: np.ndarray) -> np.ndarray:
    """Distance (len(points), n) from each point (rows x, y) to each segment (columns x0, y0, x1, y1)."""
    x0, y0, x1, y1 = ends
    ex, ey = x1 - x0, y1 - y0
    px, py = points[:, :1] - x0, points[:, 1:] - y0
    along = np.clip((px * ex + py * ey) / np.maximum(ex * ex + ey * ey, 1e-300), 0.0, 1.0)
    distance: np.ndarray = np.hypot(px - along * ex, py - along * ey)
    return distance


def _segment_boxes(segments: np.ndarray) -> np.ndarray:
    x0, y0, x1, y1 = segments[:4]
    return np.array([np.minimum(x0, x1), np.minimum(y0, y1), np.maximum(x0, x1), np.maximum(y0, y1)])


def _circle_boxes(circles: np.ndarray) -> np.ndarray:
    cx, cy, r = circles[:3]
    return np.array([cx - r, cy - r, cx + r, cy + r])


class Grid:
    """Square cells of side `size` (m); items are registered in every cell their box, grown by `reach`,
    overlaps (long items: see the module's doc)."""

    def __init__(self, footprints: Footprints, fan: Fan, size: float | None = None) -> None:
        reach = fan.range_max
        self.size = size or max(reach / 2.0, 1.0)
        self.floors = np.ascontiguousarray(footprints.floors, dtype=float)
        self._flat: FlatWalls | bool | None = None  # False: none (too sparse)
        tables = (footprints.segments, footprints.circles, footprints.bounds)
        boxes = (
            _segment_boxes(footprints.segments),
            _circle_boxes(footprints.circles),
            _circle_boxes(footprints.bounds),
        )
        per_table, long = zip(*(self._register(box, reach) for box in boxes))
        segments, circles, bounds = (table[:, items] for table, items in zip(tables, long))
        self.empty = Cell(segments, circles, bounds, fan)
        keys = set().union(*(cells.keys() for cells in per_table))
        near_long = self._near_long(keys, tables, long, reach)
        self.cells: dict[tuple[int, int], Cell] = {}
        for key in keys:
            segments, circles, bounds = (
                table[:, _merged(cells.get(key), near.get(key))]
                for table, cells, near in zip(tables, per_table, near_long)
            )
            self.cells[key] = Cell(
                segments, circles, bounds, fan, ((key[0] + 0.5) * self.size, (key[1] + 0.5) * self.size)
            )

    @property
    def has_items(self) -> bool:
        """Whether the grid holds anything: a cell of its own, or long items."""
        return bool(self.cells) or any(
            table.shape[1] for table in (self.empty.segments, self.empty.circles, self.empty.bounds)
        )

    def _register(self, boxes: np.ndarray, reach: float) -> tuple[dict[tuple[int, int], np.ndarray], np.ndarray]:
        """The items (columns of `boxes`) of each cell, and the long items (registered in no cell)."""
        lo = np.floor((boxes[:2] - reach) / self.size)
        hi = np.floor((boxes[2:] + reach) / self.size)
        long = np.flatnonzero((hi[0] - lo[0] + 1) * (hi[1] - lo[1] + 1) > LONG_CELLS)  # floats: no overflow
        registered = np.ones(boxes.shape[1], bool)
        registered[long] = False
        short = np.flatnonzero(registered)  # np.setdiff1d's answer, without its import of numpy.ma
        lo, hi = lo[:, short].astype(np.int64), hi[:, short].astype(np.int64)
        nx, ny = hi[0] - lo[0] + 1, hi[1] - lo[1] + 1
        counts = nx * ny
        item = np.repeat(short, counts)
        k = np.arange(counts.sum()) - np.repeat(np.cumsum(counts) - counts, counts)  # index within the item's block
        ix = np.repeat(lo[0], counts) + k % np.repeat(nx, counts)
        iy = np.repeat(lo[1], counts) + k // np.repeat(nx, counts)
        order = np.lexsort((item, iy, ix))
        ix, iy, item = ix[order], iy[order], item[order]
        if len(ix) == 0:
            return {}, long
        starts = np.flatnonzero(np.r_[True, (np.diff(ix) != 0) | (np.diff(iy) != 0)])
        ends = np.r_[starts[1:], len(ix)]
        return {(int(ix[s]), int(iy[s])): item[s:e] for s, e in zip(starts, ends)}, long

    def _near_long(
        self, keys: set[tuple[int, int]], tables: tuple[np.ndarray, ...], long: tuple[np.ndarray, ...], reach: float
    ) -> list[dict[tuple[int, int], np.ndarray]]:
        """Per table, the long items within reach of each cell in `keys` (of any point of it)."""
        found: list[dict[tuple[int, int], np.ndarray]] = [{}, {}, {}]
        if not keys or not any(len(items) for items in long):
            return found
        ordered = sorted(keys)
        centres = (np.array(ordered, dtype=float) + 0.5) * self.size
        room = (reach + self.size * math.sqrt(0.5)) * (1.0 + 1e-9)  # from a cell's centre: its farthest point's reach
        for k, (table, items) in enumerate(zip(tables, long)):
            step = max(1, (1 << 20) // max(len(items), 1))  # cells per block: the distance table stays small
            for first in range(0, len(ordered) if len(items) else 0, step):
                block = centres[first : first + step]
                if k == 0:
                    distance = _segment_distances(block, table[:4, items])
                else:
                    gap = np.hypot(block[:, :1] - table[0, items], block[:, 1:] - table[1, items])
                    distance = gap - table[2, items]
                for key, near in zip(ordered[first : first + step], distance <= room):
                    if near.any():
                        found[k][key] = items[near]
        return found

    def flat_walls(self) -> FlatWalls | None:
        """The walls-only cells as arrays for a compiled caller (kernels' tables, concatenated), built once; None
        where their look-up table would be too large (cells strewn kilometres apart: more than FLAT_CELLS)."""
        if self._flat is None:
            self._flat = FlatWalls.of(self)
        return self._flat if isinstance(self._flat, FlatWalls) else None

    def cell(self, x: float, y: float) -> Cell:
        """The items near the point (x, y)."""
        return self.cells.get((math.floor(x / self.size), math.floor(y / self.size)), self.empty)


@dataclass(frozen=True)
class FlatWalls:
    """A Grid's walls-only cells for compiled code: cell (ix, iy) (floor(x / size), floor(y / size)) has number
    ids[ix - x0, iy - y0], or `outside` where (ix, iy) lies outside `ids`; -1 where the cell holds more than walls
    (a cell the grid has no items for is its `empty` cell: the long walls, or none). Cell k's walls are
    table[:, starts[k]:starts[k + 1]]: kernels.wall_table rows, or, if `dense` (a cell of dense.DENSE_WALLS walls or
    more: a map), dense.py's dense_table rows. `floors`: the heights of the world's horizontal planes."""

    floors: np.ndarray
    size: float
    x0: int
    y0: int
    ids: np.ndarray
    starts: np.ndarray
    table: np.ndarray
    dense: bool = False
    outside: int = -1

    @classmethod
    def of(cls, grid: Grid) -> FlatWalls | bool:
        """The grid's walls-only cells; False if their look-up table would hold more than FLAT_CELLS cells."""
        from racecar_sim.sensors.raycast.dense import DENSE_WALLS, dense_order, dense_table

        cells = {key: cell for key, cell in grid.cells.items() if cell.level_table() is not None}
        empty = grid.empty if grid.empty.level_table() is not None else None
        keys = list(cells)
        if keys:
            x0, y0 = min(k[0] for k in keys), min(k[1] for k in keys)
            shape = (max(k[0] for k in keys) - x0 + 1, max(k[1] for k in keys) - y0 + 1)
        else:
            x0, y0, shape = 0, 0, (1, 1)
        if shape[0] * shape[1] > FLAT_CELLS:
            return False
        listed = [cells[key] for key in keys] + ([empty] if empty is not None else [])
        dense = max((cell.segments.shape[1] for cell in listed), default=0) >= DENSE_WALLS
        tables = []
        for cell in listed:
            if dense:
                segments = cell.segments[:, dense_order(cell.segments, cell.centre)]
                tables.append(dense_table(segments, cell.fan.range_min, cell.fan.range_max))
            else:
                table = cell.level_table()
                assert table is not None  # `listed` holds only such cells
                tables.append(table)
        outside = len(keys) if empty is not None else -1
        ids = np.full(shape, outside, np.int64)
        for key in grid.cells:  # cells with more than walls: refused
            if key not in cells and 0 <= key[0] - x0 < shape[0] and 0 <= key[1] - y0 < shape[1]:
                ids[key[0] - x0, key[1] - y0] = -1
        for number, key in enumerate(keys):
            ids[key[0] - x0, key[1] - y0] = number
        starts = np.concatenate([[0], np.cumsum([t.shape[1] for t in tables])]).astype(np.int64)
        from racecar_sim.sensors.raycast.kernels import WALL_ROWS

        rows = tables[0].shape[0] if tables else WALL_ROWS
        table = np.concatenate(tables, axis=1) if tables else np.zeros((rows, 0))
        return cls(grid.floors, grid.size, x0, y0, ids, starts, np.ascontiguousarray(table), dense, outside)
