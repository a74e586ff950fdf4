"""Mesh files (STL, OBJ, DAE and what else trimesh reads) as `Mesh` parts with their colours and textures.

COLLADA `<unit meter>` is applied and `<up_axis>` is not, as Gazebo's ColladaLoader does.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path
from typing import TYPE_CHECKING, cast

import numpy as np

from racecar_sim.core.errors import WorldError
from racecar_sim.worlds.world import Mesh

if TYPE_CHECKING:
    import trimesh


@dataclass
class MeshPart:
    """One sub-mesh of a file, with the colour or texture its file gives it (None: the SDF material decides)."""

    mesh: Mesh
    rgba: tuple[float, float, float, float] | None = None
    texture: np.ndarray | None = None


def load_mesh(path: Path, scale: tuple[float, float, float] = (1.0, 1.0, 1.0)) -> list[MeshPart]:
    """The parts of a mesh file, scaled to metres and then by `scale`; WorldError names the file if unreadable."""
    path = Path(path)
    if not path.is_file():
        raise WorldError(f"mesh file {path} does not exist")
    return list(_load(path.resolve(), path.stat().st_mtime_ns, tuple(scale)))


@lru_cache(maxsize=64)
def _load(path: Path, mtime_ns: int, scale: tuple[float, float, float]) -> tuple[MeshPart, ...]:
    import trimesh  # scipy and networkx with it: 0.4 s, paid only by a world or car with meshes

    try:
        scene = cast("trimesh.Scene", trimesh.load(path, force="scene"))  # force="scene": always a Scene
    except Exception as exc:  # trimesh raises many kinds for a bad file; all mean the same to a user
        raise WorldError(f"mesh file {path} cannot be read: {exc}") from None
    if scene.units and scene.units != "meters":
        scene = scene.convert_units("meters")
    parts = []
    for geometry in scene.dump():
        if not isinstance(geometry, trimesh.Trimesh) or len(geometry.faces) == 0:
            continue
        vertices = np.asarray(geometry.vertices, dtype=np.float64) * np.asarray(scale)
        mesh = Mesh(vertices, np.asarray(geometry.faces, dtype=np.int32), source=str(path))
        rgba, texture = _appearance(geometry, mesh)
        parts.append(MeshPart(mesh, rgba, texture))
    if not parts:
        raise WorldError(f"mesh file {path} holds no triangles")
    return tuple(parts)


def _appearance(geometry: trimesh.Trimesh, mesh: Mesh) -> tuple[tuple | None, np.ndarray | None]:
    import trimesh

    visual = geometry.visual
    if isinstance(visual, trimesh.visual.TextureVisuals):
        material = visual.material
        image = getattr(material, "image", None) or getattr(material, "baseColorTexture", None)
        if image is not None and visual.uv is not None and len(visual.uv) == len(mesh.vertices):
            mesh.texcoord = np.asarray(visual.uv, dtype=np.float32)
            return None, np.asarray(image.convert("RGBA"))
        color = getattr(material, "baseColorFactor", None)
        if color is None:
            color = getattr(material, "diffuse", None)
        return (tuple(np.asarray(color, dtype=float)[:4] / 255.0) if color is not None else None), None
    if isinstance(visual, trimesh.visual.ColorVisuals) and visual.defined:
        return tuple(np.asarray(visual.main_color, dtype=float) / 255.0), None
    return None, None


def convex_pieces(mesh: Mesh) -> tuple[list[Mesh], bool]:
    """The mesh's connected pieces (MuJoCo collides with each piece's convex hull), and whether all are convex."""
    import trimesh

    tm = trimesh.Trimesh(mesh.vertices, mesh.faces, process=True)
    pieces = tm.split(only_watertight=False) if tm.body_count > 1 else [tm]
    meshes = [Mesh(np.asarray(p.vertices), np.asarray(p.faces, dtype=np.int32), source=mesh.source) for p in pieces]
    return meshes, all(p.is_convex for p in pieces)


def textured_box(size: tuple[float, float, float]) -> Mesh:
    """A box of full extents `size` as 24 vertices with each face mapped to the whole image (as an SDF box is)."""
    half = np.asarray(size, dtype=np.float64) / 2
    vertices: list[np.ndarray] = []
    texcoord: list[tuple[int, int]] = []
    faces: list[tuple[int, int, int]] = []
    for axis in range(3):
        u_axis, v_axis = [a for a in range(3) if a != axis]
        for sign in (1.0, -1.0):
            base = len(vertices)
            for u, v in ((0, 0), (1, 0), (1, 1), (0, 1)):
                p = np.zeros(3)
                p[axis] = sign * half[axis]
                # seen from outside, u runs right and v up on every face
                p[u_axis] = (u - 0.5) * 2 * half[u_axis] * (sign if axis != 1 else -sign)
                p[v_axis] = (v - 0.5) * 2 * half[v_axis]
                vertices.append(p)
                texcoord.append((u, v))
            faces += [(base, base + 1, base + 2), (base, base + 2, base + 3)]
    return Mesh(np.array(vertices), np.array(faces, dtype=np.int32), np.array(texcoord, dtype=np.float32), "box")
