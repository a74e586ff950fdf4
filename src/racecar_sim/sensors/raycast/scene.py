"""What a horizontal-ish scan can hit, read from the compiled model as exact 2-D footprints.

A geom is a *vertical prism* when its cross-section does not change with height over its z-range: a box
with one axis vertical, an upright cylinder, a mesh made only of vertical and horizontal faces (an
extruded outline). Within its z-range such a geom is exactly its footprint: segments (polygon edges) or a
circle. Every other geom (sphere, capsule, ellipsoid, a tilted box or cylinder, a cone-shaped mesh) is
kept only as a bounding cylinder, and beams that may reach it are cast in 3-D. A horizontal plane is a
floor; anything else (a sloped plane, a height field) makes every scan 3-D.

Arrays are row-major tables, one column per item:
  segments  (13, n): x0, y0, x1, y1, zlo, zhi, mid x, mid y, half length, the owning geom's footprint
                     circle cx, cy, r (for beams that might pass over or under it), and 1 for an edge of a
                     convex footprint wound counter-clockwise (seen only from outside), else 0
  circles   (5, n):  cx, cy, r, zlo, zhi
  bounds    (5, n):  the same, for geoms that are not prisms (a bounding cylinder)
"""

from __future__ import annotations

from dataclasses import dataclass, field

import mujoco
import numpy as np

G = mujoco.mjtGeom
SEGMENT_ROWS, CIRCLE_ROWS = 13, 5
# the geom types solids.cast_solids casts exactly (moving geoms: other cars, pushable boxes)
SPHERE, CAPSULE, ELLIPSOID, CYLINDER, BOX = (
    int(G.mjGEOM_SPHERE),
    int(G.mjGEOM_CAPSULE),
    int(G.mjGEOM_ELLIPSOID),
    int(G.mjGEOM_CYLINDER),
    int(G.mjGEOM_BOX),
)
KINDS = (SPHERE, CAPSULE, ELLIPSOID, CYLINDER, BOX)
VERTICAL_TOL = 1e-6  # sine of the largest tilt still taken as vertical: float32 mesh noise (a 2.5 m wall moves 2.5 µm)


def empty_segments() -> np.ndarray:
    """A segment table with no columns."""
    return np.zeros((SEGMENT_ROWS, 0))


def empty_circles() -> np.ndarray:
    """A circle (or bound) table with no columns."""
    return np.zeros((CIRCLE_ROWS, 0))


@dataclass
class Footprints:
    """Exact 2-D footprints of prisms, bounding cylinders of the rest, floors, and what forces 3-D."""

    segments: np.ndarray = field(default_factory=empty_segments)
    circles: np.ndarray = field(default_factory=empty_circles)
    bounds: np.ndarray = field(default_factory=empty_circles)
    floors: np.ndarray = field(default_factory=lambda: np.zeros(0))  # heights of horizontal planes
    not_prism_like: list[str] = field(default_factory=list)  # geoms that make every scan 3-D

    @classmethod
    def join(cls, parts: list[Footprints]) -> Footprints:
        """All parts' footprints in one."""
        return cls(
            np.concatenate([empty_segments()] + [p.segments for p in parts], axis=1),
            np.concatenate([empty_circles()] + [p.circles for p in parts], axis=1),
            np.concatenate([empty_circles()] + [p.bounds for p in parts], axis=1),
            np.concatenate([np.zeros(0)] + [p.floors for p in parts]),
            [name for p in parts for name in p.not_prism_like],
        )


@dataclass(frozen=True)
class Solids:
    """Geoms cast exactly by solids.cast_solids (beam by beam, with MuJoCo's formulas): their ids in the model, types,
    sizes (n, 3) and bounding radii."""

    ids: np.ndarray  # intp
    types: np.ndarray  # intp
    sizes: np.ndarray  # (n, 3) float64
    rbound: np.ndarray  # float64

    @classmethod
    def of(cls, model: mujoco.MjModel, geoms: np.ndarray) -> Solids | None:
        """The geoms as solids, or None when one of them is of a type solids.cast_solids does not cast (a mesh, a
        plane, a height field)."""
        geoms = np.asarray(geoms, np.intp)
        types = model.geom_type[geoms].astype(np.intp)
        if not np.isin(types, KINDS).all():
            return None
        return cls(
            np.ascontiguousarray(geoms),
            np.ascontiguousarray(types),
            np.ascontiguousarray(model.geom_size[geoms], dtype=np.float64).reshape(-1, 3),
            np.ascontiguousarray(model.geom_rbound[geoms], dtype=np.float64),
        )

    def __len__(self) -> int:
        return len(self.ids)


def seen_geoms(model: mujoco.MjModel, group: int) -> np.ndarray:
    """Ids of the geoms a ray cast with only `group` enabled can hit (mj_ray also skips invisible ones: alpha 0 in
    the geom's material, or in its own rgba when it has none; a model may have no materials at all)."""
    alpha = model.geom_rgba[:, 3].copy()
    with_material = np.flatnonzero(model.geom_matid >= 0)
    alpha[with_material] = model.mat_rgba[model.geom_matid[with_material], 3]
    groups = np.clip(model.geom_group, 0, mujoco.mjNGROUP - 1)
    return np.flatnonzero((groups == group) & (alpha != 0))


def subtree_bodies(model: mujoco.MjModel, root: int) -> np.ndarray:
    """Ids of `root` and every body below it."""
    if root > 0 and model.body_parentid[root] == 0:  # a top-level body (a car): the bodies whose root it is
        return np.flatnonzero(model.body_rootid == root)
    inside = np.zeros(model.nbody, bool)
    inside[root] = True
    for body in range(root + 1, model.nbody):  # MuJoCo numbers parents before their children
        inside[body] = inside[model.body_parentid[body]]
    return np.flatnonzero(inside)


def is_static(model: mujoco.MjModel, geom: int) -> bool:
    """Whether the geom is welded to the world (and not a mocap body, which can be moved)."""
    body = model.geom_bodyid[geom]
    return bool(model.body_weldid[body] == 0 and model.body_mocapid[body] < 0)


def static_geoms(model: mujoco.MjModel, geoms: np.ndarray) -> np.ndarray:
    """is_static for each of `geoms` (bool array), in a few array operations."""
    bodies = model.geom_bodyid[geoms]
    static: np.ndarray = (model.body_weldid[bodies] == 0) & (model.body_mocapid[bodies] < 0)
    return static


def _vertical_axis(rotation: np.ndarray) -> int | None:
    for k in range(3):
        if abs(rotation[0, k]) <= VERTICAL_TOL and abs(rotation[1, k]) <= VERTICAL_TOL:
            return k
    return None


def _polygon_segments(corners: np.ndarray, zlo: float, zhi: float) -> np.ndarray:
    """The convex polygon `corners` (n, 2) as one-sided segment columns, each knowing the polygon's circle."""
    x, y = corners[:, 0], corners[:, 1]
    if np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)) < 0:  # wind counter-clockwise
        corners = corners[::-1]
    a, b = corners, np.roll(corners, -1, axis=0)
    centre = 0.5 * (corners.min(axis=0) + corners.max(axis=0))
    return _segments(a, b, zlo, zhi, centre, float(np.linalg.norm(corners - centre, axis=1).max()), one_sided=True)


def _segments(
    a: np.ndarray, b: np.ndarray, zlo: float, zhi: float, centre: np.ndarray, radius: float, one_sided: bool = False
) -> np.ndarray:
    n = len(a)
    mid = 0.5 * (a + b)
    half = 0.5 * np.linalg.norm(b - a, axis=1)
    z = np.full(n, 1.0)
    return np.array(
        [
            a[:, 0],
            a[:, 1],
            b[:, 0],
            b[:, 1],
            zlo * z,
            zhi * z,
            mid[:, 0],
            mid[:, 1],
            half,
            centre[0] * z,
            centre[1] * z,
            radius * z,
            float(one_sided) * z,
        ]
    )[:, half > 0]


def _bound(pos: np.ndarray, radius: float) -> Footprints:
    column = np.array([[pos[0]], [pos[1]], [radius], [pos[2] - radius], [pos[2] + radius]])
    return Footprints(bounds=column)


def box_footprint(pos: np.ndarray, rotation: np.ndarray, half: np.ndarray) -> Footprints | None:
    """A box with a vertical axis as its four footprint edges; None if it is tilted."""
    k = _vertical_axis(rotation)
    if k is None:
        return None
    i, j = [axis for axis in range(3) if axis != k]
    a, b = rotation[:2, i] * half[i], rotation[:2, j] * half[j]
    corners = pos[:2] + np.array([a + b, -a + b, -a - b, a - b])
    return Footprints(segments=_polygon_segments(corners, pos[2] - half[k], pos[2] + half[k]))


def boxes_footprints(pos: np.ndarray, rotations: np.ndarray, half: np.ndarray) -> Footprints:
    """Footprints of boxes given as arrays (n, 3), (n, 3, 3), (n, 3): exact for upright ones, a bound otherwise."""
    return Footprints.join(
        [box_footprint(p, r, h) or _bound(p, float(np.linalg.norm(h))) for p, r, h in zip(pos, rotations, half)]
    )


def cylinder_footprint(pos: np.ndarray, rotation: np.ndarray, size: np.ndarray) -> Footprints | None:
    """An upright cylinder as its footprint circle; None if it is tilted."""
    if _vertical_axis(rotation) != 2:
        return None
    column = np.array([[pos[0]], [pos[1]], [size[0]], [pos[2] - size[1]], [pos[2] + size[1]]])
    return Footprints(circles=column)


def mesh_footprint(vertices: np.ndarray, faces: np.ndarray) -> Footprints | None:
    """A mesh (world vertices (n, 3), faces (m, 3)) that is an extruded outline, as the outline's edges.

    It qualifies when every vertex lies on its bottom or top level and every face is horizontal or
    vertical; each side face then cuts the mid-height plane in a segment valid at every height.
    """
    z = vertices[:, 2]
    zlo, zhi = float(z.min()), float(z.max())
    tol = VERTICAL_TOL * max(1.0, float(np.ptp(vertices, axis=0).max()))
    top = np.abs(z - zhi) <= tol
    if zhi - zlo <= tol or not np.all(top | (np.abs(z - zlo) <= tol)):
        return None
    tri = vertices[faces]
    normal = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    level = top[faces]
    sides = level.any(axis=1) & ~level.all(axis=1)
    if np.any(np.abs(normal[sides, 2]) > VERTICAL_TOL * np.linalg.norm(normal[sides], axis=1)):
        return None
    if not sides.any():
        return None
    tri, level = tri[sides, :, :2], level[sides]
    lone = np.argmax(level != (level.sum(axis=1) > 1)[:, None], axis=1)  # the vertex alone on its level
    rows = np.arange(len(tri))
    apex = tri[rows, lone]
    a, b = 0.5 * (apex + tri[rows, (lone + 1) % 3]), 0.5 * (apex + tri[rows, (lone + 2) % 3])
    centre = 0.5 * (vertices[:, :2].min(axis=0) + vertices[:, :2].max(axis=0))
    radius = float(np.linalg.norm(vertices[:, :2] - centre, axis=1).max())
    return Footprints(segments=_segments(a, b, zlo, zhi, centre, radius))


def mesh_vertices(
    model: mujoco.MjModel, mesh: int, pos: np.ndarray, rotation: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """World vertices and faces of a mesh geom, exactly as MuJoCo's ray casts see them."""
    adr, num = model.mesh_vertadr[mesh], model.mesh_vertnum[mesh]
    local = model.mesh_vert[adr : adr + num].astype(float)
    fadr, fnum = model.mesh_faceadr[mesh], model.mesh_facenum[mesh]
    return pos + local @ rotation.T, model.mesh_face[fadr : fadr + fnum]


def geom_footprint(
    model: mujoco.MjModel, geom: int, pos: np.ndarray, rotation: np.ndarray, allow_mesh: bool = True
) -> Footprints:
    """The footprint of one geom at the given world pose (exact for prisms, a bound otherwise)."""
    kind, size = int(model.geom_type[geom]), model.geom_size[geom]
    found: Footprints | None = None
    if kind == G.mjGEOM_PLANE:
        if _vertical_axis(rotation) == 2:
            return Footprints(floors=np.array([pos[2]]))
        return Footprints(not_prism_like=[_name(model, geom)])
    if kind in (G.mjGEOM_HFIELD, G.mjGEOM_SDF) or kind not in _KNOWN:
        return Footprints(not_prism_like=[_name(model, geom)])
    if kind == G.mjGEOM_BOX:
        found = box_footprint(pos, rotation, size)
    elif kind == G.mjGEOM_CYLINDER:
        found = cylinder_footprint(pos, rotation, size)
    elif kind == G.mjGEOM_MESH and allow_mesh:
        found = mesh_footprint(*mesh_vertices(model, model.geom_dataid[geom], pos, rotation))
    return found if found is not None else _bound(pos, float(model.geom_rbound[geom]))


_KNOWN = {
    int(kind)
    for kind in (
        G.mjGEOM_PLANE,
        G.mjGEOM_HFIELD,
        G.mjGEOM_SPHERE,
        G.mjGEOM_CAPSULE,
        G.mjGEOM_ELLIPSOID,
        G.mjGEOM_CYLINDER,
        G.mjGEOM_BOX,
        G.mjGEOM_MESH,
        G.mjGEOM_SDF,
    )
}


def _name(model: mujoco.MjModel, geom: int) -> str:
    return model.geom(geom).name or f"geom {geom}"


def static_footprints(model: mujoco.MjModel, geoms: np.ndarray) -> Footprints:
    """Footprints of the static geoms among `geoms`, at their (fixed) world poses."""
    scratch = mujoco.MjData(model)  # static poses do not depend on the state; leave the caller's data alone
    mujoco.mj_kinematics(model, scratch)
    parts = [
        geom_footprint(model, g, scratch.geom_xpos[g].copy(), scratch.geom_xmat[g].reshape(3, 3).copy()) for g in geoms
    ]
    return Footprints.join(parts)
