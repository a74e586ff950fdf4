"""Top-down maps of worlds: every geom's footprint in the xy plane on a matplotlib Axes, and a PNG writer.

draw_world only draws; save_world_png makes, frames and saves a figure, so trajectories can be drawn later on
top of the same Axes.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.collections import PolyCollection
from matplotlib.figure import Figure

from racecar_sim.core.geometry import convex_hull
from racecar_sim.core.transforms import compose, quat_to_matrix
from racecar_sim.worlds.world import Spawn, World, WorldBody, WorldGeom

FLOOR_DEPTH = 0.3  # m below the spawn height: geoms entirely lower are floors
FLAT = 0.02  # m: thinner geoms are floor markings
CIRCLE_SEGMENTS = 48
INFINITE_PLANE = 1e4  # m, drawn size of a plane of size 0 (MuJoCo's infinite plane)
COLLISION_ONLY_FILL = (0.25, 0.25, 0.25, 1.0)
OUTLINE = (0.0, 0.0, 0.0, 1.0)
SPAWN_COLOR = (0.85, 0.05, 0.05, 1.0)
SPAWN_ARROW = 28.0  # points
EMPTY_HALF_WIDTH = 5.0  # m shown around the spawn when the world has nothing but planes
MARGIN = 0.05  # of the larger side, and at least MIN_MARGIN
MIN_MARGIN = 0.5  # m
MAX_ASPECT = 3.0  # longer side over shorter side of the framed map
# Layers: ground planes, grid (0.5 with axisbelow), floors, walls, the spawn pose on top.
Z_PLANE, Z_FLOOR, Z_WALL, Z_SPAWN = 0.2, 1.0, 2.0, 5.0
Z_SPAWN_LABEL = 7.0  # over a run summary's path, start line and race marks, so it reads


@dataclass
class Footprint:
    """A geom's outline seen from above: a convex polygon in world xy, and its world z range."""

    body: WorldBody
    geom: WorldGeom
    xy: np.ndarray  # (K, 2), counter-clockwise
    zmin: float
    zmax: float

    @property
    def height(self) -> float:
        """Vertical extent, m."""
        return self.zmax - self.zmin


def _local_points(geom: WorldGeom) -> np.ndarray:
    """Points in the geom's frame whose hull is the shape (exact for boxes and meshes, polygons for round ones)."""
    angles = np.linspace(0.0, 2 * math.pi, CIRCLE_SEGMENTS, endpoint=False)
    ring = np.c_[np.cos(angles), np.sin(angles)]  # unit circle in the geom's xy plane
    if geom.kind == "box":
        half = np.asarray(geom.size[:3]) / 2
        return np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)]) * half
    if geom.kind == "plane":
        sx, sy = (s if s > 0 else INFINITE_PLANE for s in geom.size[:2])
        return np.array([[-sx, -sy, 0], [sx, -sy, 0], [sx, sy, 0], [-sx, sy, 0]]) / 2
    if geom.kind == "cylinder":
        radius, length = geom.size[:2]
        return np.vstack([np.c_[radius * ring, np.full(len(ring), z)] for z in (-length / 2, length / 2)])
    if geom.kind == "sphere":  # the horizontal great circle and the poles
        radius = geom.size[0]
        return np.vstack([np.c_[radius * ring, np.zeros(len(ring))], [[0, 0, -radius], [0, 0, radius]]])
    if geom.kind == "mesh" and geom.mesh is not None and len(geom.mesh.vertices):
        return np.asarray(geom.mesh.vertices, dtype=float)
    return np.zeros((0, 3))


def footprint(body: WorldBody, geom: WorldGeom) -> Footprint | None:
    """The geom's footprint in world coordinates (geom pose composed with its body's); None if it has no shape."""
    local = _local_points(geom)
    if not len(local):
        return None
    pos, quat = compose(
        np.asarray(body.pos, float),
        np.asarray(body.quat, float),
        np.asarray(geom.pos, float),
        np.asarray(geom.quat, float),
    )
    world = local @ quat_to_matrix(quat).T + pos
    return Footprint(body, geom, convex_hull(world[:, :2]), float(world[:, 2].min()), float(world[:, 2].max()))


def footprints(world: World) -> list[Footprint]:
    """Footprints of every geom of the world, planes included."""
    return [f for body, geom in world.geoms() if (f := footprint(body, geom)) is not None]


def finite_points(prints: list[Footprint]) -> np.ndarray:
    """(K, 2) corners of every footprint but the planes' (a ground plane is drawn, never framed): what a
    picture of the whole world must show."""
    points = [f.xy for f in prints if f.geom.kind != "plane" and len(f.xy)]
    return np.vstack(points) if points else np.zeros((0, 2))


def world_extent(world: World) -> tuple[float, float, float, float]:
    """(xmin, xmax, ymin, ymax) of the non-plane geoms and the spawn point, plus a margin; ±5 m if only planes.

    The shorter side is widened, about the centre, to at least a third of the longer one.
    """
    return _extent(footprints(world), world.spawn)


def _extent(prints: list[Footprint], s: Spawn) -> tuple[float, float, float, float]:
    points = finite_points(prints)
    if not len(points):
        return s.x - EMPTY_HALF_WIDTH, s.x + EMPTY_HALF_WIDTH, s.y - EMPTY_HALF_WIDTH, s.y + EMPTY_HALF_WIDTH
    xy = np.vstack([points, [[s.x, s.y]]])
    lo, hi = xy.min(axis=0), xy.max(axis=0)
    margin = max(MIN_MARGIN, MARGIN * float((hi - lo).max()))
    lo, hi = lo - margin, hi + margin
    half = np.maximum((hi - lo) / 2, (hi - lo).max() / (2 * MAX_ASPECT))
    centre = (lo + hi) / 2
    return centre[0] - half[0], centre[0] + half[0], centre[1] - half[1], centre[1] + half[1]


def _fill(geom: WorldGeom) -> tuple[float, float, float, float]:
    """The geom's colour; a texture tints it by its mean colour, as the renderer multiplies the two."""
    r, g, b, a = geom.rgba
    if geom.texture is not None:
        mean = np.asarray(geom.texture, dtype=float)[..., :3].reshape(-1, 3).mean(axis=0) / 255.0
        r, g, b = r * mean[0], g * mean[1], b * mean[2]
    return float(r), float(g), float(b), float(a)


def _inside_convex(point: np.ndarray, hull: np.ndarray, tol: float = 1e-6) -> bool:
    """Whether a point lies in (or on) a counter-clockwise convex polygon."""
    edges = np.roll(hull, -1, axis=0) - hull
    rel = point - hull
    return bool(np.all(edges[:, 0] * rel[:, 1] - edges[:, 1] * rel[:, 0] >= -tol * np.hypot(*edges.T)))


class _Visuals:
    """One body's visual footprints, as arrays, to ask whether one of them covers a collision geom."""

    def __init__(self, prints: list[Footprint]) -> None:
        self.prints = [f for f in prints if len(f.xy) >= 3]
        self.lo = np.array([f.xy.min(axis=0) for f in self.prints]).reshape(-1, 2) - 1e-6
        self.hi = np.array([f.xy.max(axis=0) for f in self.prints]).reshape(-1, 2) + 1e-6
        self.zmin = np.array([f.zmin for f in self.prints])
        self.zmax = np.array([f.zmax for f in self.prints])

    def cover(self, c: Footprint) -> bool:
        """Whether a visual contains the collision geom's centre and spans over half its height."""
        centre = c.xy.mean(axis=0)
        overlap = np.minimum(self.zmax, c.zmax) - np.maximum(self.zmin, c.zmin)
        in_box = np.all(centre >= self.lo, axis=1) & np.all(centre <= self.hi, axis=1)
        near = in_box & (overlap >= 0.5 * c.height - 1e-6)
        return any(_inside_convex(centre, self.prints[i].xy) for i in np.flatnonzero(near))


def _is_floor(f: Footprint, spawn: Spawn) -> bool:
    return f.zmax < spawn.z - FLOOR_DEPTH or f.height < FLAT


def draw_world(ax: Axes, world: World, prints: list[Footprint] | None = None) -> None:
    """Draw the world from above on `ax` (metres, x right, y up, equal aspect) and mark its spawn pose.

    Visual geoms are filled with their colour, collision geoms outlined in black, and collision geoms no visual
    covers filled dark grey. Planes lie underneath everything, floors and flat markings under the walls.
    prints: the world's footprints, when the caller has them already.
    """
    _draw(ax, footprints(world) if prints is None else prints, world.spawn)


def _draw(ax: Axes, prints: list[Footprint], spawn: Spawn) -> None:
    by_body: dict[int, list[Footprint]] = {}
    for f in prints:
        if not f.geom.collides:
            by_body.setdefault(id(f.body), []).append(f)
    visuals = {key: _Visuals(group) for key, group in by_body.items()}
    layers: dict[tuple[float, str], list[tuple[np.ndarray, tuple]]] = {}
    for f in sorted(prints, key=lambda f: f.zmax):  # higher things drawn over lower ones within a layer
        if f.geom.kind == "plane":
            if not f.geom.collides:
                layers.setdefault((Z_PLANE, "fill"), []).append((f.xy, _fill(f.geom)))
            continue
        z = Z_FLOOR if _is_floor(f, spawn) else Z_WALL
        if not f.geom.collides:
            layers.setdefault((z, "fill"), []).append((f.xy, _fill(f.geom)))
            continue
        layers.setdefault((z + 0.1, "edge"), []).append((f.xy, OUTLINE))
        if id(f.body) not in visuals or not visuals[id(f.body)].cover(f):
            layers.setdefault((z, "fill"), []).append((f.xy, COLLISION_ONLY_FILL))
    for (z, style), items in sorted(layers.items()):
        verts = [xy for xy, _ in items]
        colors = [color for _, color in items]
        if style == "fill":
            # Edges in the fill colour keep geoms seen edge-on (a standing tag, a vertical plane) visible.
            col = PolyCollection(verts, facecolors=colors, edgecolors=colors, linewidths=0.4, zorder=z)
        else:
            col = PolyCollection(verts, facecolors="none", edgecolors=colors, linewidths=0.6, zorder=z)
        ax.add_collection(col, autolim=z != Z_PLANE)  # a 150 m ground plane must not set the view
    draw_spawn(ax, spawn)
    ax.set_aspect("equal")
    ax.autoscale_view()


def draw_spawn(ax: Axes, spawn: Spawn) -> None:
    """Mark a spawn pose: a red dot, an arrow along its heading (fixed on-screen length) and a label beside it."""
    c, s = math.cos(spawn.yaw), math.sin(spawn.yaw)
    ax.plot([spawn.x], [spawn.y], "o", color=SPAWN_COLOR, markersize=5, zorder=Z_SPAWN)
    # The head sits at the offset end (posA), so the arrow keeps its on-screen length at any map scale.
    ax.annotate(
        "",
        (spawn.x, spawn.y),
        xytext=(SPAWN_ARROW * c, SPAWN_ARROW * s),
        textcoords="offset points",
        arrowprops={
            "arrowstyle": "<|-,head_length=0.6,head_width=0.3",
            "color": SPAWN_COLOR,
            "lw": 1.8,
            "shrinkA": 0,
            "shrinkB": 0,
        },
        zorder=Z_SPAWN,
    )
    # The label sits on the car's right and runs along its heading, so it stays beside the arrow, inside the map.
    ha = "left" if c > 0.3 or (c >= -0.3 and s > 0) else "right"
    va = "top" if c > 0.3 else "bottom" if c < -0.3 else "center"
    ax.annotate(
        f"spawn ({spawn.x:g}, {spawn.y:g}, yaw {spawn.yaw:g})",
        (spawn.x, spawn.y),
        xytext=(8 * s, -8 * c),
        textcoords="offset points",
        ha=ha,
        va=va,
        color=SPAWN_COLOR,
        fontsize=8,
        zorder=Z_SPAWN_LABEL,
        bbox={"boxstyle": "round,pad=0.15", "facecolor": "white", "alpha": 0.8, "linewidth": 0},  # over a path
    )


def world_figure(world: World, size: float = 8.0) -> tuple[Figure, Axes]:
    """A figure (not attached to pyplot) with the world drawn, titled, labelled, gridded and framed.

    size: the map's longer side, inches (the title and axis labels add about 0.8 in).
    """
    prints = footprints(world)
    xmin, xmax, ymin, ymax = _extent(prints, world.spawn)
    aspect = (ymax - ymin) / (xmax - xmin)
    figsize = (size, size * aspect + 0.8) if aspect <= 1 else (size / aspect + 0.8, size)
    fig = Figure(figsize=figsize, layout="constrained")
    FigureCanvasAgg(fig)
    ax = fig.add_subplot()
    _draw(ax, prints, world.spawn)
    ax.set_xlim(xmin, xmax)
    ax.set_ylim(ymin, ymax)
    ax.set_title(world.name)
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_axisbelow(True)
    ax.grid(True, color=(0.3, 0.3, 0.3), alpha=0.35, linewidth=0.5)
    return fig, ax


def save_world_png(world: World, path: str | Path, dpi: int = 150) -> Path:
    """Write a top-down PNG of the world (Agg, no global matplotlib state); returns the path written."""
    fig, _ = world_figure(world)
    path = Path(path)
    fig.savefig(path, format="png", dpi=dpi)
    return path
