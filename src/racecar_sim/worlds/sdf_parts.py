"""The small pieces of SDF: numbers, poses, URIs, geometry and materials, each checked with a one-line error.

`SdfContext` carries the file being read (errors and warnings name it) and the model search path.
"""

from __future__ import annotations

import math
import os
import warnings
import xml.etree.ElementTree as ET
from collections.abc import Iterator
from pathlib import Path
from typing import Literal, overload

import numpy as np

from racecar_sim.core.errors import WorldError
from racecar_sim.core.transforms import quat_from_rpy, quat_mul
from racecar_sim.description.ros_packages import gazebo_model_dirs
from racecar_sim.worlds.images import rgba_pixels
from racecar_sim.worlds.materials import gazebo_material_rgba
from racecar_sim.worlds.mesh_surface import surface_pieces
from racecar_sim.worlds.meshes import MeshPart, convex_pieces, load_mesh, textured_box
from racecar_sim.worlds.world import Mesh, WorldGeom

BUILTIN_MODELS = Path(__file__).parent / "data" / "models"
DEFAULT_RGBA = (0.7, 0.7, 0.7, 1.0)
# Children the loader reads, or that have no effect on a ground robot's physics, sensors or pictures.
GEOMETRY_SHAPES = ("box", "cylinder", "sphere", "plane", "mesh", "capsule", "ellipsoid")
_MATERIAL_KNOWN = {"script", "ambient", "diffuse", "specular", "emissive", "pbr", "lighting", "double_sided"}


class SdfContext:
    """Where we are: the SDF file (for messages and relative URIs) and the folders that hold model:// models.

    `includes`: the chain of <include>s that led here from the world file `root`, (uri, file) each; `names`: the
    full names of the models, links, collisions and visuals read so far (shared by every file of one world), as
    MuJoCo and Gazebo take no name twice.
    """

    def __init__(
        self,
        source: Path,
        model_path: list[Path],
        warned: set[tuple[Path, str, str]] | None = None,
        includes: tuple[tuple[str, Path], ...] = (),
        names: set[tuple[str, str]] | None = None,
        root: Path | None = None,
    ) -> None:
        self.source = source
        self.model_path = model_path
        self.warned: set[tuple[Path, str, str]] = set() if warned is None else warned  # (file, element, where)
        self.includes = includes
        self.names: set[tuple[str, str]] = set() if names is None else names  # (kind, full name)
        self.root = source if root is None else root

    def inside(self, source: Path, uri: str = "") -> SdfContext:
        """The context for a file included by `uri`: same search path, one shared set of warnings and of names. An
        include that leads back to a file on its own chain (a model that includes itself, A includes B includes A)
        is a WorldError naming the world file and the URIs."""
        chain = (*self.includes, (uri, source))
        if source.resolve() in {self.root.resolve(), *(file.resolve() for _, file in self.includes)}:
            raise WorldError(
                f"{self.root}: <include> loop: {' -> '.join(u for u, _ in chain)} ({source} is included "
                "again inside itself)"
            )
        return SdfContext(source, self.model_path, self.warned, chain, self.names, self.root)

    def claim(self, key: tuple[str, str], message: str) -> None:
        """Take a name (kind, full name) of a model, link or shape; WorldError(message) if it is taken already."""
        if key in self.names:
            raise self.error(message)
        self.names.add(key)

    def error(self, message: str) -> WorldError:
        return WorldError(f"{self.source}: {message}")

    def warn(self, element: str, where: str = "", why: str = "is not supported and was ignored") -> None:
        key = (self.source, element, where)
        if key in self.warned:
            return
        self.warned.add(key)
        place = f" in {where}" if where else ""
        warnings.warn(f"{self.source}: <{element}>{place} {why}", stacklevel=4)

    def warn_unknown(self, el: ET.Element, known: set[str] | tuple[str, ...], where: str) -> None:
        """Warn once for each child of `el` the loader does not read."""
        for child in el:
            if child.tag not in known and isinstance(child.tag, str):
                self.warn(child.tag, where)

    def search_path(self) -> Iterator[Path]:
        """The built-in models, --model-path, then what Gazebo with gazebo_ros searches (GAZEBO_MODEL_PATH, the
        packages on ROS_PACKAGE_PATH: their gazebo_model_path exports and the folders that hold them); lazily, so
        that the built-in models never wait for a crawl of the package path."""
        yield BUILTIN_MODELS
        yield from self.model_path
        yield from gazebo_model_dirs()


@overload
def numbers(text: str | None, n: Literal[3], ctx: SdfContext, where: str) -> tuple[float, float, float]: ...
@overload
def numbers(text: str | None, n: Literal[4], ctx: SdfContext, where: str) -> tuple[float, float, float, float]: ...
@overload
def numbers(text: str | None, n: int, ctx: SdfContext, where: str) -> tuple[float, ...]: ...
def numbers(text: str | None, n: int, ctx: SdfContext, where: str) -> tuple[float, ...]:
    """Exactly n finite numbers from whitespace-separated text (a tuple of n)."""
    try:
        values = tuple(float(v) for v in (text or "").split())
    except ValueError:
        raise ctx.error(f"{where}: '{text}' is not {n} numbers") from None
    if len(values) != n or not all(math.isfinite(v) for v in values):
        raise ctx.error(f"{where}: '{(text or '').strip()}' is not {n} finite numbers")
    return values


def number(el: ET.Element, tag: str, default: float, ctx: SdfContext, where: str) -> float:
    """The finite number in child `tag`, or `default` when it is absent."""
    text = el.findtext(tag)
    return default if text is None or not text.strip() else numbers(text, 1, ctx, f"{where} <{tag}>")[0]


def flag(el: ET.Element, tag: str, default: bool) -> bool:
    text = el.findtext(tag)
    return default if text is None else text.strip().lower() in ("true", "1")


def pose(el: ET.Element, ctx: SdfContext, where: str) -> tuple[np.ndarray, np.ndarray] | None:
    """The element's <pose> as (position, quaternion wxyz), or None when it has none."""
    pose_el = el.find("pose")
    if pose_el is None or not (pose_el.text or "").strip():
        return None
    if pose_el.get("relative_to"):
        ctx.warn(
            f"pose relative_to='{pose_el.get('relative_to')}'",
            where,
            "is not supported; the pose is taken relative to the parent frame",
        )
    if pose_el.get("rotation_format", "euler_rpy") == "quat_xyzw":
        v = numbers(pose_el.text, 7, ctx, f"{where} <pose>")
        quat = np.array([v[6], v[3], v[4], v[5]])
        norm = np.linalg.norm(quat)
        if norm < 1e-9:
            raise ctx.error(f"{where} <pose>: quaternion is zero")
        return np.array(v[:3]), quat / norm
    v = numbers(pose_el.text, 6, ctx, f"{where} <pose>")
    rpy = np.radians(v[3:]) if pose_el.get("degrees", "false").lower() == "true" else v[3:]
    return np.array(v[:3]), quat_from_rpy(rpy)


def pose_or_identity(el: ET.Element, ctx: SdfContext, where: str) -> tuple[np.ndarray, np.ndarray]:
    return pose(el, ctx, where) or (np.zeros(3), np.array([1.0, 0.0, 0.0, 0.0]))


def resolve_uri(uri: str, ctx: SdfContext, where: str) -> Path:
    """model://name/rest through the model path, file:// and plain paths relative to the current file."""
    uri = uri.strip()
    if uri.startswith("model://"):
        name, _, rest = uri[len("model://") :].partition("/")
        for folder in ctx.search_path():
            if (folder / name).is_dir():
                return folder / name / rest
        raise ctx.error(
            f"{where}: {uri}: model '{name}' not found in "
            f"{os.pathsep.join(str(p) for p in ctx.search_path())} (add its folder with --model-path, or "
            "the folder of the package that holds it with --package-path)"
        )
    if uri.startswith("file://"):
        uri = uri[len("file://") :]
    elif "://" in uri:
        raise ctx.error(f"{where}: {uri}: only model://, file:// and plain paths are supported")
    path = Path(uri)
    return path if path.is_absolute() else ctx.source.parent / path


def _plane_quat(normal: tuple[float, ...]) -> np.ndarray:
    z = np.array(normal) / np.linalg.norm(normal)
    axis = np.cross([0.0, 0.0, 1.0], z)
    angle = math.atan2(np.linalg.norm(axis), z[2])
    if np.linalg.norm(axis) < 1e-12:
        axis = np.array([1.0, 0.0, 0.0])
    axis = axis / np.linalg.norm(axis)
    return np.r_[math.cos(angle / 2), math.sin(angle / 2) * axis]


def shapes(el: ET.Element, collides: bool, ctx: SdfContext, where: str, static: bool = False) -> list[WorldGeom]:
    """The geoms of one <collision> or <visual>: usually one, one per part or piece for meshes (a `static` link's
    collision mesh collides as its surface, a free link's as convex hulls)."""
    geometry = el.find("geometry")
    if geometry is None or len(geometry) == 0:
        raise ctx.error(f"{where}: <geometry> is missing or empty")
    g = geometry[0]
    pos, quat = pose_or_identity(el, ctx, where)
    kind = g.tag
    size: tuple[float, ...] = ()
    box: tuple[float, float, float] | None = None  # the size of a box
    if kind == "box":
        size = box = numbers(g.findtext("size"), 3, ctx, f"{where} box <size>")
    elif kind in ("cylinder", "capsule"):
        size = (number(g, "radius", math.nan, ctx, where), number(g, "length", math.nan, ctx, where))
    elif kind == "sphere":
        size = (number(g, "radius", math.nan, ctx, where),)
    elif kind == "ellipsoid":
        size = numbers(g.findtext("radii"), 3, ctx, f"{where} ellipsoid <radii>")
    elif kind == "plane":
        normal = numbers(g.findtext("normal") or "0 0 1", 3, ctx, f"{where} plane <normal>")
        if np.linalg.norm(normal) < 1e-9:
            raise ctx.error(f"{where} plane <normal>: the normal is zero")
        size = numbers(g.findtext("size") or "100 100", 2, ctx, f"{where} plane <size>")
        quat = quat_mul(quat, _plane_quat(normal))
    elif kind == "mesh":
        return _mesh_shapes(g, el, collides, static, pos, quat, ctx, where)
    else:
        ctx.warn(kind, f"{where} <geometry>")
        return []
    if any(not (s > 0) for s in size):
        raise ctx.error(f"{where} <{kind}>: sizes must be positive, got {' '.join(f'{s:g}' for s in size)}")
    geom = WorldGeom(where, kind, size, pos, quat, collides=collides)
    texture = None if collides else albedo_map(el.find("material"), ctx, where)
    if texture is not None and box is not None:
        geom.kind, geom.size, geom.mesh, geom.texture = "mesh", (), textured_box(box), texture
    elif texture is not None:
        ctx.warn("albedo_map", where, f"is only drawn on boxes and meshes, not on a {kind}")
    return [geom]


def _mesh_shapes(
    g: ET.Element,
    el: ET.Element,
    collides: bool,
    static: bool,
    pos: np.ndarray,
    quat: np.ndarray,
    ctx: SdfContext,
    where: str,
) -> list[WorldGeom]:
    uri = g.findtext("uri")
    if not uri or not uri.strip():
        raise ctx.error(f"{where} <mesh>: <uri> is missing")
    path = resolve_uri(uri, ctx, f"{where} <mesh><uri>")
    if not path.is_file():
        raise ctx.error(f"{where} <mesh><uri>{uri.strip()}</uri>: mesh file {path} not found")
    scale = numbers(g.findtext("scale") or "1 1 1", 3, ctx, f"{where} <mesh><scale>")
    ctx.warn_unknown(g, {"uri", "scale"}, f"{where} <mesh>")
    try:
        parts = load_mesh(path, scale)
    except WorldError as exc:
        raise ctx.error(f"{where} <mesh>: {exc}") from None
    geoms = []
    if collides:
        geoms = [
            WorldGeom(where, "mesh", (), pos, quat, collides=True, mesh=m)
            for m in _collision_pieces(parts, static, uri.strip(), ctx, where)
        ]
    else:
        material = el.find("material")
        texture = albedo_map(material, ctx, where)
        for part in parts:
            rgba = rgba_of(material, ctx, where) if material is not None or part.rgba is None else part.rgba
            part_texture = texture if texture is not None and part.mesh.texcoord is not None else part.texture
            geoms.append(
                WorldGeom(where, "mesh", (), pos, quat, collides=False, rgba=rgba, mesh=part.mesh, texture=part_texture)
            )
    for i, geom in enumerate(geoms[1:], start=1):
        geom.name = f"{where}#{i}"
    return geoms


def _collision_pieces(parts: list[MeshPart], static: bool, uri: str, ctx: SdfContext, where: str) -> list[Mesh]:
    """A static mesh collides as its surface (as Gazebo collides with its triangles): convex pieces whole, the
    rest as flat convex pieces. A free body's collides as the convex hulls of its connected pieces (thin
    triangles make poor contacts for a moving body)."""
    pieces: list[Mesh] = []
    flat = 0  # flat pieces standing for the non-convex parts of a static mesh
    convex = True
    for part in parts:
        if static:
            part_pieces, part_flat = surface_pieces(part.mesh)
            flat += part_flat
        else:
            part_pieces, part_convex = convex_pieces(part.mesh)
            convex = convex and part_convex
            for piece in part_pieces:
                if is_flat(piece.vertices):
                    raise ctx.error(
                        f"{where} <mesh><uri>{uri}</uri>: a free model's collision mesh collides as the "
                        f"convex hull of each connected piece, and one piece is flat (triangles: "
                        f"{len(piece.faces)}, vertices: {len(piece.vertices)}): make the model <static> "
                        "(it then collides as its faces) or give the mesh thickness"
                    )
        pieces += part_pieces
    if flat:
        ctx.warn(
            f"mesh><uri>{uri}</uri",
            where,
            f"is not convex: as in Gazebo, it collides as its faces where it is "
            f"not ({flat} flat pieces: coplanar faces merged while convex)",
        )
    elif not convex:
        ctx.warn(
            f"mesh><uri>{uri}</uri",
            where,
            "is not convex: it collides as the convex hull of each of its connected pieces",
        )
    return pieces


def is_flat(vertices: np.ndarray, thinness: float = 1e-6) -> bool:
    """Whether points (n, 3) have no convex hull with volume: fewer than 4, or all within `thinness` x their size
    of one plane (MuJoCo refuses the hull of coplanar points; qhull warns from about 1e-8)."""
    if len(vertices) < 4:
        return True
    spread = np.linalg.svd(vertices - vertices.mean(axis=0), compute_uv=False)
    return not spread[2] > thinness * spread[0]


def rgba_of(material: ET.Element | None, ctx: SdfContext, where: str) -> tuple[float, float, float, float]:
    """A <material>'s colour: a Gazebo script name, else diffuse, else ambient."""
    if material is None:
        return DEFAULT_RGBA
    ctx.warn_unknown(material, _MATERIAL_KNOWN, f"{where} <material>")
    script_name = material.findtext("script/name")
    if script_name and script_name.strip():
        return gazebo_material_rgba(script_name.strip())
    for tag in ("diffuse", "ambient"):
        text = material.findtext(tag)
        if text and text.strip():
            values = text.split()
            return numbers(" ".join(values + ["1"] * (len(values) == 3)), 4, ctx, f"{where} <material><{tag}>")
    return DEFAULT_RGBA


def albedo_map(material: ET.Element | None, ctx: SdfContext, where: str) -> np.ndarray | None:
    """The image of <pbr><metal|specular><albedo_map>, as an RGBA array."""
    if material is None:
        return None
    text = material.findtext("pbr/metal/albedo_map") or material.findtext("pbr/specular/albedo_map")
    if not text or not text.strip():
        return None
    path = resolve_uri(text, ctx, f"{where} <albedo_map>")
    try:
        return rgba_pixels(path, lambda message: ctx.error(f"{where} <albedo_map>: {message}"), "texture")
    except (OSError, ValueError) as exc:
        raise ctx.error(f"{where} <albedo_map>{text.strip()}</albedo_map>: cannot read image {path}: {exc}") from None
