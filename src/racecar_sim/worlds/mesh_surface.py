"""A static mesh's surface as convex pieces MuJoCo can collide with, as Gazebo collides with its triangles.

MuJoCo collides a mesh as its convex hull, so a non-convex piece (a race course's wall tops: one flat,
ring-shaped region) would fill its whole interior. Gazebo's ODE collides with the triangles themselves.
`surface_pieces` keeps every convex connected piece whole and splits the others into planar regions
(faces sharing a plane within PLANE_TOL and an edge), each region into convex polygons (its triangles,
merged while the union stays convex: Hertel-Mehlhorn), and each polygon into a slab SLAB_THICKNESS thick
behind its face, so that the surface stays where the file puts it and the hull MuJoCo builds is not
degenerate (qhull prints warnings on stderr about a flat one, or MuJoCo rejects it). A face within
NORMAL_TOL of level or upright is made exactly so (CAD exports carry float noise): its slab is then an
exact vertical prism, which the lidar's 2-D caster slices without falling back to 3-D casts.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from racecar_sim.core.geometry import convex_hull
from racecar_sim.worlds.world import Mesh

if TYPE_CHECKING:
    import trimesh

SLAB_THICKNESS = 1e-3  # m, behind each flat piece: thin enough to stay inside any wall, thick enough for qhull
PLANE_TOL = 1e-4  # m, largest distance of a region's vertex from the region's plane
NORMAL_TOL = 1e-3  # rad, largest angle between the normals of two faces of one region
_TURN_TOL = 1e-7  # sine of the largest inward turn still taken as straight (float noise along an edge)
_AREA_TOL = 1e-6  # relative: a region is convex when its area is its 2-D convex hull's


def surface_pieces(mesh: Mesh) -> tuple[list[Mesh], int]:
    """The pieces a static mesh collides as, and how many flat pieces stand for its non-convex parts (0: it is
    convex piece by piece; a flat convex piece, such as one quad, counts as convex)."""
    import trimesh  # scipy and networkx with it: 0.4 s, paid only by a world with meshes

    tm = trimesh.Trimesh(mesh.vertices, mesh.faces, process=True)
    pieces = tm.split(only_watertight=False) if tm.body_count > 1 else [tm]
    meshes: list[Mesh] = []
    split = 0
    for piece in pieces:
        if piece.is_convex and abs(piece.volume) > 0:  # flat: MuJoCo cannot hull it
            meshes.append(Mesh(np.asarray(piece.vertices), np.asarray(piece.faces, dtype=np.int32), source=mesh.source))
            continue
        surface = _Surface(piece)
        slabs = [slab for region in surface.planar_regions() for slab in surface.slabs(region)]
        meshes += [Mesh(vertices, faces, source=mesh.source) for vertices, faces in slabs]
        split += len(slabs) if len(slabs) > 1 else 0
    return meshes, split


class _Surface:
    """One connected piece's triangles and how they meet, read from trimesh once (its cached properties hash the
    mesh on every access)."""

    def __init__(self, tm: trimesh.Trimesh) -> None:
        self.vertices = np.asarray(tm.vertices)
        self.faces = np.asarray(tm.faces)
        self.normals = np.asarray(tm.face_normals)
        self.areas = np.asarray(tm.area_faces)
        self.pairs = np.asarray(tm.face_adjacency)  # faces sharing an edge
        self.edges = np.asarray(tm.face_adjacency_edges)  # that edge's vertices
        self.unshared = np.asarray(tm.face_adjacency_unshared)  # each face's vertex off that edge

    def planar_regions(self) -> list[np.ndarray]:
        """Face indices of each edge-connected set of faces on one plane (degenerate faces left out)."""
        keep = self.areas > 1e-12
        first, second = self.pairs[:, 0], self.pairs[:, 1]
        same_way = np.einsum("ij,ij->i", self.normals[first], self.normals[second]) >= np.cos(NORMAL_TOL)
        # the second face's vertex off the shared edge lies on the first face's plane
        off = self.vertices[self.unshared[:, 1]] - self.vertices[self.faces[first, 0]]
        on_plane = np.abs(np.einsum("ij,ij->i", off, self.normals[first])) <= PLANE_TOL
        joined = self.pairs[same_way & on_plane & keep[self.pairs].all(axis=1)]
        import trimesh

        groups = trimesh.graph.connected_components(joined, nodes=np.flatnonzero(keep), min_len=1)
        return [np.sort(g) for g in groups]

    def slabs(self, region: np.ndarray) -> list[tuple[np.ndarray, np.ndarray]]:
        """The region as convex slabs; a region that drifts off one plane (a finely curved surface) as one slab
        per triangle, each on its own plane."""
        normal = (self.normals[region] * self.areas[region, None]).sum(axis=0)
        normal /= np.linalg.norm(normal)
        used = np.unique(self.faces[region])
        origin = self.vertices[used].mean(axis=0)
        level = _levelled(normal)
        if np.abs((self.vertices[used] - origin) @ level).max() <= PLANE_TOL:
            normal = level
        elif len(region) > 1 and np.abs((self.vertices[used] - origin) @ normal).max() > PLANE_TOL:
            return [slab for face in region for slab in self.slabs(np.array([face]))]
        u, v = _plane_axes(normal)
        flat = (self.vertices - origin) @ np.column_stack([u, v])  # every vertex's coordinates in the plane
        if normal[2] == 0.0:  # upright: corners at nearly one height (float noise in the file) share it
            flat[used, 1] = _snapped(flat[used, 1])
        faces = self.faces[region]
        area = _signed_areas(flat, faces)
        faces = np.where((area < 0)[:, None], faces[:, ::-1], faces)  # a face wound against the rest: turn it
        hull = convex_hull(flat[used])
        hull_area = _polygon_area(hull)
        if abs(np.abs(area).sum() - hull_area) <= _AREA_TOL * hull_area:
            polygons = [hull]
        else:
            polygons = [flat[loop] for loop in self._convex_partition(flat, faces, region)]
        polygons = [_straightened(p) for p in polygons]
        return [_slab(p, origin, u, v, normal) for p in polygons if len(p) >= 3 and _polygon_area(p) > 1e-12]

    def _convex_partition(self, flat: np.ndarray, faces: np.ndarray, region: np.ndarray) -> list[list[int]]:
        """Counter-clockwise vertex loops of convex polygons covering the region's triangles: each triangle
        first, then neighbours merged across their shared edge (longest first) while the union stays convex."""
        loops: dict[int, list[int]] = {i: list(face) for i, face in enumerate(faces.tolist())}
        owner = list(range(len(faces)))  # triangle -> the loop it is now part of
        index = {int(face): i for i, face in enumerate(region)}
        inside = np.isin(self.pairs, region).all(axis=1)
        pairs, edges = self.pairs[inside], self.edges[inside]
        lengths = np.linalg.norm(flat[edges[:, 0]] - flat[edges[:, 1]], axis=1)
        for k in np.argsort(-lengths):
            a, b = (_root(owner, index[int(f)]) for f in pairs[k])
            if a == b:
                continue
            merged = _merge(loops[a], loops[b], *edges[k].tolist())
            if merged is None or not _is_convex(flat[merged]):
                continue
            loops[a] = merged
            del loops[b]
            owner[b] = a
        return list(loops.values())


def _levelled(normal: np.ndarray) -> np.ndarray:
    """The normal made exactly vertical or exactly horizontal when it is within NORMAL_TOL of that: level and
    upright faces then give slabs that are exact vertical prisms, which the 2-D lidar slices exactly."""
    if abs(normal[2]) >= np.cos(NORMAL_TOL):
        return np.array([0.0, 0.0, np.sign(normal[2])])
    if abs(normal[2]) <= np.sin(NORMAL_TOL):
        return np.array([normal[0], normal[1], 0.0]) / np.hypot(normal[0], normal[1])
    return normal


def _plane_axes(normal: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Unit axes u, v of the plane with u x v = normal; v straight up on an upright plane."""
    if normal[2] == 0.0:
        return np.array([-normal[1], normal[0], 0.0]), np.array([0.0, 0.0, 1.0])
    helper = np.eye(3)[np.argmin(np.abs(normal))]
    u = np.cross(helper, normal)
    u /= np.linalg.norm(u)
    return u, np.cross(normal, u)


def _snapped(values: np.ndarray) -> np.ndarray:
    """Each run of values less than PLANE_TOL apart replaced by the run's mean."""
    order = np.argsort(values)
    runs = np.cumsum(np.r_[0, np.diff(values[order]) > PLANE_TOL])
    means = np.bincount(runs, values[order]) / np.bincount(runs)
    snapped = np.empty_like(values)
    snapped[order] = means[runs]
    return snapped


def _signed_areas(points: np.ndarray, faces: np.ndarray) -> np.ndarray:
    a, b, c = points[faces[:, 0]], points[faces[:, 1]], points[faces[:, 2]]
    return 0.5 * ((b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0]))


def _polygon_area(points: np.ndarray) -> float:
    x, y = points[:, 0], points[:, 1]
    return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)))


def _root(owner: list[int], i: int) -> int:
    while owner[i] != i:
        owner[i] = owner[owner[i]]
        i = owner[i]
    return i


def _merge(p: list[int], q: list[int], a: int, b: int) -> list[int] | None:
    """Loops p and q joined across their shared edge a-b; None unless that is the only thing they share."""
    if len(set(p) & set(q)) != 2:
        return None
    x, y = (a, b) if _has_edge(p, a, b) else (b, a)  # p runs x -> y, q runs y -> x
    if not (_has_edge(p, x, y) and _has_edge(q, y, x)):
        return None
    i, j = p.index(y), q.index(x)
    p_from_y = p[i:] + p[:i]  # y ... x
    q_from_x = q[j:] + q[:j]  # x ... y
    return p_from_y + q_from_x[1:-1]


def _has_edge(loop: list[int], a: int, b: int) -> bool:
    i = loop.index(a) if a in loop else -1
    return i >= 0 and loop[(i + 1) % len(loop)] == b


def _turns(points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """At each corner of a closed polygon: the cross product of the edges in and out, and their lengths' product."""
    e_in = points - np.roll(points, 1, axis=0)
    e_out = np.roll(points, -1, axis=0) - points
    cross = e_in[:, 0] * e_out[:, 1] - e_in[:, 1] * e_out[:, 0]
    return cross, np.linalg.norm(e_in, axis=1) * np.linalg.norm(e_out, axis=1)


def _is_convex(points: np.ndarray) -> bool:
    cross, scale = _turns(points)
    return bool(np.all(cross >= -_TURN_TOL * scale))


def _straightened(points: np.ndarray) -> np.ndarray:
    """The polygon without the corners where it runs straight on (T-junctions of the triangulation)."""
    cross, scale = _turns(points)
    return points[cross > _TURN_TOL * scale]


def _slab(
    polygon: np.ndarray, origin: np.ndarray, u: np.ndarray, v: np.ndarray, normal: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """A convex counter-clockwise polygon in the plane (origin, u, v) as a closed prism reaching SLAB_THICKNESS
    behind it (against `normal`): vertices and outward-wound faces."""
    n = len(polygon)
    face = origin + polygon[:, :1] * u + polygon[:, 1:] * v
    vertices = np.vstack([face, face - SLAB_THICKNESS * normal])
    fan = np.arange(1, n - 1)
    front = np.column_stack([np.zeros(n - 2, int), fan, fan + 1])
    back = np.column_stack([np.full(n - 2, n), fan + 1 + n, fan + n])
    i = np.arange(n)
    j = (i + 1) % n
    sides = np.vstack([np.column_stack([i, i + n, j]), np.column_stack([j, i + n, j + n])])
    return vertices, np.vstack([front, back, sides]).astype(np.int32)
