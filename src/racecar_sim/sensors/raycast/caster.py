"""RayCaster: a planar scan cast in 2-D wherever that is exact, and in 3-D (MuJoCo) wherever it is not.

Per scan, the beams stay inside a height band around the sensor (range_max x the tilt of the scan plane).
A vertical prism whose z-range covers the band is cast in 2-D (exact at any tilt, see fan.py); beams that
may reach anything else inside the band - a prism that only partly covers it, a sphere, a cone mesh, a
tilted pushed box - are recast in 3-D, and a floor inside the band (a ramp, a crash) sends the whole scan
to 3-D. Beams that can only reach prisms never leave the fast path, so a level scan of a walled world
costs tens of microseconds; the answer is the same as the 3-D cast's either way.
"""

from __future__ import annotations

import weakref
from collections.abc import Callable

import mujoco
import numpy as np

from racecar_sim.physics.near_walls import WallBoxes
from racecar_sim.sensors.raycast.fan import MAX_TILT_COS, Fan, ScanFrame, plane_band
from racecar_sim.sensors.raycast.grid import FlatWalls, Grid, split_by_band
from racecar_sim.sensors.raycast.mujoco3d import MujocoRays
from racecar_sim.sensors.raycast.planar import (
    Walls,
    cast_circles,
    circle_spans,
    near_items,
)
from racecar_sim.sensors.raycast.scene import (
    Footprints,
    Solids,
    boxes_footprints,
    geom_footprint,
    seen_geoms,
    static_footprints,
    static_geoms,
    subtree_bodies,
)

MODES = ("auto", "3d")
G = mujoco.mjtGeom
_ALWAYS_BOUNDED = [int(kind) for kind in (G.mjGEOM_SPHERE, G.mjGEOM_CAPSULE, G.mjGEOM_ELLIPSOID, G.mjGEOM_MESH)]


class RayCaster:
    """Casts a `Fan` of beams from a pose in a compiled model, seeing the geoms of `group` except the
    bodies under `own_body` (the robot carrying the sensor).

    Static geoms are cut into footprints once, here; free bodies (pushable cones, boxes) are looked at
    from their current pose on every scan. `last_3d_beams` tells how many beams the last scan cast in 3-D.
    `pose_bodies`, if given, is called before a cast first reads body poses from `data` (free bodies, 3-D
    casts), so that a scan that needs none leaves `data` unposed.
    """

    def __init__(
        self,
        model: mujoco.MjModel,
        data: mujoco.MjData,
        fan: Fan,
        own_body: int,
        group: int,
        cell_size: float | None = None,
        pose_bodies: Callable[[], None] | None = None,
    ) -> None:
        self.fan, self.group, self.cell_size = fan, group, cell_size
        self._pose_bodies = pose_bodies or (lambda: None)
        self.rebind(model, data, own_body)

    def rebind(self, model: mujoco.MjModel, data: mujoco.MjData, own_body: int) -> None:
        """Cast in a recompiled model (a model was spawned or deleted): the world is sliced again (milliseconds)."""
        self.model, self.data = model, data
        fan, group, cell_size = self.fan, self.group, self.cell_size
        geoms = seen_geoms(model, group)
        own = np.isin(model.geom_bodyid[geoms], subtree_bodies(model, own_body))
        static = static_geoms(model, geoms)
        walls = WallBoxes.of(model)  # a map's walls, held out of the model's geoms (physics.near_walls)
        self.static, self.grid = _sliced(model, geoms[static & ~own], walls, fan, cell_size)
        moving = geoms[~static & ~own]
        bounded = np.isin(model.geom_type[moving], _ALWAYS_BOUNDED)
        self.moving_bounded, self.moving_other = moving[bounded], moving[~bounded]
        self._has_moving = len(moving) > 0
        # the moving geoms (other cars, pushable boxes) as solids the compiled scan casts exactly; None if one of
        # them is of a kind it does not cast (a mesh): scans near them then take the general path
        self.solids = Solids.of(model, moving)
        # walls or solids to cast: the compiled kernels (numba) are in use
        self.compiled = self.grid.has_items or bool(self.solids)
        self.rays3d = MujocoRays(model, data, group, geoms[own], walls)
        self.last_3d_beams = 0
        # the heights of the floors where they are all this world holds for a scan (an empty world, one car): a level
        # scan whose band holds none of them hits nothing (misses_everything); None where the world holds more
        bare = not (self._has_moving or self.grid.has_items or self.static.not_prism_like)
        self.floors_only: tuple[float, ...] | None = tuple(self.static.floors.tolist()) if bare else None

    def cast(self, origin: np.ndarray, rotation: np.ndarray, mode: str = "auto") -> np.ndarray:
        """Range (m) of every beam from `origin` (world, 3) along the sensor axes `rotation` (world from
        sensor, 3x3): the first hit at or beyond range_min, inf if none within range_max.

        mode "3d" casts every beam with MuJoCo (the reference the fast path is tested against).
        """
        if mode not in MODES:
            raise ValueError(f"ray cast mode '{mode}' is not one of {', '.join(MODES)}")
        if mode == "auto" and not self._has_moving and not self.static.not_prism_like:
            table = self.grid.cell(origin[0], origin[1]).walls_only()
            if table is not None:  # walls only near the sensor: one compiled call, unless it needs the general path
                from racecar_sim.sensors.raycast import level  # numba: loaded by the first world with walls

                fan = self.fan
                ranges = np.full(fan.count, np.inf)
                if level.cast_level(
                    table,
                    self.static.floors,
                    origin,
                    rotation,
                    MAX_TILT_COS,
                    fan.angle_min,
                    fan.inverse_step,
                    fan.count,
                    fan.turn,
                    fan.range_min,
                    fan.range_max,
                    fan.directions,
                    ranges,
                ):
                    self.last_3d_beams = 0
                    return ranges
        frame = ScanFrame(origin, rotation, self.fan)
        if mode == "3d" or _needs_3d(frame, self.static):
            return self._cast_3d(frame)
        moving = None
        if self._has_moving:
            self._pose_bodies()
            moving = self._moving(frame)
            if _needs_3d(frame, moving):
                return self._cast_3d(frame)
        ranges = np.full(self.fan.count, np.inf)
        unsure: list[tuple[int, int]] = []  # beam intervals to recast in 3-D
        lo, hi = frame.band
        cell = self.grid.cell(frame.origin[0], frame.origin[1])
        _cast_prisms(frame, *cell.split(lo, hi), ranges, unsure)
        mark_bounds(frame, cell.bounds, unsure)
        if moving is not None:
            segments, circles, partly = split_by_band(moving.segments, moving.circles, lo, hi)
            _cast_prisms(frame, Walls(segments, self.fan), circles, partly, ranges, unsure)
            mark_bounds(frame, moving.bounds, unsure)
        ranges[ranges > self.fan.range_max] = np.inf
        self.last_3d_beams = 0
        if unsure:
            beams = np.flatnonzero(_mask(unsure, self.fan.count))
            self.last_3d_beams = len(beams)
            if moving is None:
                self._pose_bodies()
            ranges[beams] = self.rays3d.cast(frame, beams)
        return ranges

    def misses_everything(self, z: float, rotation: list[list[float]]) -> bool:
        """Whether cast() in mode auto, from height `z` along the sensor axes `rotation` (rows), gives inf for every
        beam without casting one: a world of floors alone (floors_only), a scan plane tilted by less than 60 degrees
        and no floor within its band (otherwise cast() goes 3-D, or there is something to see)."""
        floors = self.floors_only
        if floors is None:
            return False
        level_cos, lo, hi = plane_band(z, rotation, self.fan.range_max)
        return not level_cos < MAX_TILT_COS and not any(lo <= floor <= hi for floor in floors)

    def level_walls(self) -> FlatWalls | None:
        """What a compiled caller needs to cast cast()'s common case itself (level.cast_level on the walls of the
        origin's cell, then solids.cast_solids on `solids`, the moving geoms; anything it refuses goes to cast()):
        the walls-only cells, or None when no scan of this world can take that path (a moving geom that is not a
        solid, a geom that is nowhere a prism, neither walls nor solids, cells strewn too far)."""
        if (self._has_moving and self.solids is None) or self.static.not_prism_like or not self.compiled:
            return None
        return self.grid.flat_walls()

    def _cast_3d(self, frame: ScanFrame) -> np.ndarray:
        self._pose_bodies()
        self.last_3d_beams = self.fan.count
        return self.rays3d.cast(frame)

    def _moving(self, frame: ScanFrame) -> Footprints:
        """Footprints of the free bodies' geoms that may be inside the band, from their current pose."""
        d, m = self.data, self.model
        ids = self.moving_bounded
        pos, radius = d.geom_xpos[ids], m.geom_rbound[ids]
        parts = [Footprints(bounds=np.array([pos[:, 0], pos[:, 1], radius, pos[:, 2] - radius, pos[:, 2] + radius]))]
        if len(self.moving_other):
            ids = self.moving_other
            pos, radius = d.geom_xpos[ids], m.geom_rbound[ids]
            lo, hi = frame.band
            reach = np.hypot(pos[:, 0] - frame.origin[0], pos[:, 1] - frame.origin[1]) <= radius + self.fan.range_max
            maybe = (reach & (pos[:, 2] - radius <= hi) & (pos[:, 2] + radius >= lo)) | (radius == 0)
            parts += [
                geom_footprint(m, g, d.geom_xpos[g], d.geom_xmat[g].reshape(3, 3), allow_mesh=False)
                for g in ids[maybe].tolist()
            ]
        return parts[0] if len(parts) == 1 else Footprints.join(parts)


# the static world sliced, per model: every caster of one model with one fan shares it (a fleet's lidars)
_SLICED: weakref.WeakKeyDictionary[mujoco.MjModel, dict[tuple[object, ...], tuple[Footprints, Grid]]] = (
    weakref.WeakKeyDictionary()
)


def _sliced(
    model: mujoco.MjModel, geoms: np.ndarray, walls: WallBoxes | None, fan: Fan, cell_size: float | None
) -> tuple[Footprints, Grid]:
    """The footprints of the static `geoms` (and a map's `walls`) and their grid, built once per model, geoms, fan
    and cell size (the static world is the same for every car: a fleet slices it once)."""
    key = (geoms.tobytes(), fan, cell_size)
    found = _SLICED.setdefault(model, {})
    if key not in found:
        static = static_footprints(model, geoms)
        if walls is not None:
            static = Footprints.join([static, boxes_footprints(walls.pos, walls.rotations(), walls.half)])
        found[key] = (static, Grid(static, fan, cell_size))
    return found[key]


def _needs_3d(frame: ScanFrame, footprints: Footprints) -> bool:
    """Whether a whole scan must be 3-D: a steep scan plane, a floor within the band, a geom that is
    nowhere a prism (a sloped plane, a height field)."""
    lo, hi = frame.band
    return frame.steep or bool(footprints.not_prism_like) or any(lo <= z <= hi for z in footprints.floors.tolist())


def _cast_prisms(
    frame: ScanFrame,
    walls: Walls,
    circles: np.ndarray,
    partly: np.ndarray,
    ranges: np.ndarray,
    unsure: list[tuple[int, int]],
) -> None:
    walls.cast(frame, ranges)
    if circles.shape[1]:
        cast_circles(frame, circles[:, near_items(circles, frame, 0, 1, 2)], ranges)
    if partly.shape[1]:
        unsure += circle_spans(frame, partly[:, near_items(partly, frame, 0, 1, 2)])


def mark_bounds(frame: ScanFrame, bounds: np.ndarray, unsure: list[tuple[int, int]]) -> None:
    """Add the beam intervals that may reach a bounding cylinder (rows cx, cy, r, zlo, zhi) in the band."""
    if bounds.shape[1]:
        lo, hi = frame.band
        inside = near_items(bounds, frame, 0, 1, 2) & (bounds[3] <= hi) & (bounds[4] >= lo)
        unsure += circle_spans(frame, bounds[:, inside])


def _mask(spans: list[tuple[int, int]], count: int) -> np.ndarray:
    mask = np.zeros(count, bool)
    for first, last in spans:
        mask[first : last + 1] = True
    return mask
