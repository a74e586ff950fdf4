"""What a loaded world is: static and dynamic bodies with their geoms, lights, physics block, spawn pose and, where
one is known, the centerline of its course."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import numpy.typing as npt

from racecar_sim.core.errors import ConfigError, WorldError

BUILTIN_DATA = Path(__file__).resolve().parent / "data"  # the built-in worlds' SDF files
# m: every point of a world lies within this of the origin. Here a float64 position is good to 1.2e-7 m, about a
# tenth of MuJoCo's collision tolerance (ccd_tolerance, 1e-6 m); much farther, its contacts become unreliable.
MAX_COORDINATE = 1e9
SEARCH_WINDOW = 5.0  # m of arc length either side of the last projection searched for the next one


@dataclass
class Mesh:
    """A triangle mesh in its geom's frame, already scaled to metres; texcoord (one uv per vertex) when textured."""

    vertices: np.ndarray  # (N, 3) float64
    faces: np.ndarray  # (M, 3) int32
    texcoord: np.ndarray | None = None  # (N, 2) float32, v measured from the image's bottom row
    source: str = ""


@dataclass
class WorldGeom:
    """One collision or visual shape.

    size: box full extents, cylinder (radius, length), sphere (radius,), plane (x, y), mesh () with `mesh` set.
    texture: an RGB(A) image (H, W, C uint8), drawn on every face of a box, or by `mesh.texcoord` on a mesh.
    """

    name: str
    kind: str  # box | cylinder | sphere | plane | mesh
    size: tuple[float, ...]
    pos: np.ndarray
    quat: np.ndarray  # (w, x, y, z), in the owning body's frame
    collides: bool = True
    mu: float = 1.0
    mu2: float = 1.0
    rgba: tuple[float, float, float, float] = (0.7, 0.7, 0.7, 1.0)
    mesh: Mesh | None = None
    texture: np.ndarray | None = None


@dataclass
class WorldBody:
    """A model link: static (welded to the world) or free (pushable, with mass)."""

    name: str
    pos: np.ndarray
    quat: np.ndarray
    static: bool = True
    mass: float = 1.0  # SDF defaults: 1 kg, unit inertia about the link origin
    inertia: tuple[float, float, float, float, float, float] = (1.0, 1.0, 1.0, 0.0, 0.0, 0.0)  # ixx iyy izz ixy ixz iyz
    com: np.ndarray = field(default_factory=lambda: np.zeros(3))
    geoms: list[WorldGeom] = field(default_factory=list)


@dataclass
class Light:
    """A light source; directional lights use `direction`."""

    name: str
    directional: bool
    pos: np.ndarray
    direction: np.ndarray
    diffuse: tuple[float, float, float] = (0.8, 0.8, 0.8)
    cast_shadows: bool = False
    specular: tuple[float, float, float] = (0.2, 0.2, 0.2)
    attenuation: tuple[float, float, float] = (1.0, 0.0, 0.0)  # constant, linear, quadratic
    spot_cutoff: float | None = None  # rad, outer cone half-angle of a spot light


@dataclass
class Physics:
    """The world's <physics> block. None = not given (the simulator's preset decides)."""

    max_step_size: float | None = None
    gravity: tuple[float, float, float] = (0.0, 0.0, -9.8)
    iterations: int | None = None
    real_time_factor: float = 1.0


@dataclass
class Scene:
    """The world's <scene>: ambient light and sky colour for the camera and viewer."""

    ambient: tuple[float, float, float] = (0.4, 0.4, 0.4)
    background: tuple[float, float, float] = (0.7, 0.7, 0.7)
    shadows: bool = True


@dataclass(frozen=True)
class Spawn:
    """Where the car starts: position of base_link (z above the ground) and heading."""

    x: float = 0.0
    y: float = 0.0
    z: float = 0.05
    yaw: float = 0.0


class Centerline:
    """A course's centerline: a polyline (N, 2), closed (a loop) or open, with arc-length projection of points onto
    it. widths (N, 2): the right and left half-widths of a race track, whose walls are built along them; None for a
    line drawn through a course built otherwise (walker's)."""

    def __init__(self, points: np.ndarray, closed: bool, source: str = "", widths: np.ndarray | None = None) -> None:
        points = np.asarray(points, np.float64)
        if closed and len(points) > 1 and np.array_equal(points[0], points[-1]):
            points = points[:-1]
            widths = None if widths is None else widths[:-1]
        if len(points) < 2:
            raise ConfigError(f"{source or 'centerline'}: needs at least 2 points, got {len(points)}")
        self.points, self.closed, self.source = points, closed, source
        self.widths = None if widths is None else np.asarray(widths, np.float64)
        ends = np.roll(points, -1, axis=0) if closed else points[1:]
        self._start = points[: len(ends)]
        self._delta = ends - self._start
        self._seg_len = np.hypot(self._delta[:, 0], self._delta[:, 1])
        if np.any(self._seg_len == 0):
            raise ConfigError(f"{source or 'centerline'}: two consecutive points are equal")
        self._s0 = np.concatenate([[0.0], np.cumsum(self._seg_len)[:-1]])
        self.length = float(self._seg_len.sum())

    def project(self, x: float, y: float, near: float | None = None) -> float:
        """Arc length s of the point of the line nearest to (x, y); with `near`, only segments within
        SEARCH_WINDOW of arc length `near` count (the line may pass close to itself elsewhere)."""
        px, py = x - self._start[:, 0], y - self._start[:, 1]
        t = np.clip((px * self._delta[:, 0] + py * self._delta[:, 1]) / self._seg_len**2, 0.0, 1.0)
        dist = np.hypot(px - t * self._delta[:, 0], py - t * self._delta[:, 1])
        s = self._s0 + t * self._seg_len
        if near is not None:
            far = np.abs(self.wrap(s - near)) > SEARCH_WINDOW
            if not np.all(far):
                dist = np.where(far, np.inf, dist)
        return float(s[int(np.argmin(dist))])

    def wrap(self, ds: np.ndarray | float) -> np.ndarray | float:
        """An arc-length difference taken the short way round a loop (unchanged on an open line)."""
        if not self.closed:
            return ds
        half = self.length / 2
        return (np.asarray(ds) + half) % self.length - half


@dataclass
class World:
    """A loaded world. centerline: its course's, where one is known (set by the loader: a track CSV's own, a
    built-in world's from worlds.yaml), else None."""

    name: str
    source: str
    bodies: list[WorldBody] = field(default_factory=list)
    lights: list[Light] = field(default_factory=list)
    physics: Physics = field(default_factory=Physics)
    scene: Scene = field(default_factory=Scene)
    spawn: Spawn = field(default_factory=Spawn)
    centerline: Centerline | None = None

    @property
    def is_track(self) -> bool:
        """Whether the world is a race track built from its centerline (walls along both borders, widths known):
        pure-pursuit follows that line unless given a path."""
        return self.centerline is not None and self.centerline.widths is not None

    @property
    def label(self) -> str:
        """How messages name the world: its file as given, a built-in world by its name and file name."""
        if not self.source:
            return self.name
        path = Path(self.source)
        if path.resolve().parent == BUILTIN_DATA:
            return f"{self.name} ({path.name})"
        return self.source

    def check_extent(self) -> None:
        """WorldError naming the model if any geom or light lies beyond MAX_COORDINATE from the origin (or is not
        finite): checked before the model, the lidar's grid or a picture is built from it. Planes are unbounded
        anyway; their drawn size is not a coordinate."""
        for body in self.bodies:
            base = math.hypot(*body.pos)
            for geom in body.geoms:
                reach = base + math.hypot(*geom.pos) + geom_radius(geom)
                if not reach <= MAX_COORDINATE:
                    raise WorldError(
                        f"{self.label}: {geom.name} reaches {reach:.3g} m from the origin, beyond the "
                        f"largest world coordinate ({MAX_COORDINATE:g} m)"
                    )
        for light in self.lights:
            reach = math.hypot(*light.pos)
            if not reach <= MAX_COORDINATE:
                raise WorldError(
                    f"{self.label}: light {light.name} is {reach:.3g} m from the origin, beyond the "
                    f"largest world coordinate ({MAX_COORDINATE:g} m)"
                )

    def cover_ground(self, points: npt.ArrayLike, margin: float = 5.0) -> None:
        """Grow the ground planes to reach `margin` beyond every xy point given (a plane collides everywhere in
        MuJoCo, but is drawn only over its size)."""
        reach = np.abs(np.asarray(points, dtype=float)).max(axis=0) + margin
        for _, geom in self.geoms():
            if geom.kind == "plane":
                geom.size = (max(geom.size[0], 2 * reach[0]), max(geom.size[1], 2 * reach[1]))

    def geoms(self, collides: bool | None = None):
        """(body, geom) pairs, optionally only collision (True) or only visual (False) geoms."""
        for body in self.bodies:
            for geom in body.geoms:
                if collides is None or geom.collides == collides:
                    yield body, geom


def geom_radius(geom: WorldGeom) -> float:
    """How far the geom reaches from its origin (a bound; 0 for a plane, which is unbounded anyway)."""
    if geom.mesh is not None:
        vertices = geom.mesh.vertices
        scale = float(np.abs(vertices).max(initial=0.0))  # scaled: 1e300 squared must not overflow
        if not 0.0 < scale < math.inf:
            return scale
        return scale * math.sqrt(float(((vertices / scale) ** 2).sum(axis=1).max()))
    size = geom.size
    if geom.kind == "box":
        return 0.5 * math.hypot(*size[:3])
    if geom.kind == "cylinder":
        return math.hypot(size[0], 0.5 * size[1])
    if geom.kind == "capsule":
        return size[0] + 0.5 * size[1]
    if geom.kind in ("sphere", "ellipsoid"):
        return max(size)
    return 0.0
