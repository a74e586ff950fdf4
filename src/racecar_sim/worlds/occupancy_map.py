"""ROS map_server maps (a YAML file and its PGM/PNG image) as worlds: occupied cells become walls.

As map_server reads a map: p = (255 - v) / 255, or v / 255 with negate: 1, for the pixel's grey level v
(colour pixels averaged); occupied if p > occupied_thresh, free if p < free_thresh, unknown otherwise.
Only occupied cells get walls. Image row 0 is the top of the map; `origin` is the pose of the bottom-left
corner of the bottom-left cell, its yaw a rotation of the whole map about that corner.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import yaml
from PIL import Image, UnidentifiedImageError

from racecar_sim.core.errors import ConfigError, WorldError
from racecar_sim.core.tables import finite_number
from racecar_sim.core.transforms import quat_from_axis_angle, quat_rotate
from racecar_sim.worlds.images import open_image
from racecar_sim.worlds.walls import box_geoms, cell_rectangles
from racecar_sim.worlds.world import MAX_COORDINATE, Spawn, World, WorldBody, WorldGeom

MODES = ("trinary", "scale", "raw")
DEFAULTS = {"negate": 0, "occupied_thresh": 0.65, "free_thresh": 0.196, "mode": "trinary"}  # map_saver's values
SIXTEEN_BIT = ("I;16", "I;16B", "I;16L", "I")


def load_map(path: str | Path, wall_height: float, spawn: Spawn | None = None) -> World:
    """The map at `path` (map_server YAML) on Gazebo's ground plane, its occupied cells extruded to walls.

    spawn: where the car starts (default: the map origin's frame origin, facing +x, as spawn_model did).
    """
    from racecar_sim.worlds.catalog import load_world  # catalog imports this module lazily

    path = Path(path)
    meta = _read_yaml(path)
    grey, alpha = _read_image(path, meta)
    occupied = occupied_cells(grey, alpha, meta)
    ox, oy, yaw = meta["origin"]
    world = load_world("empty")
    world.name, world.source = path.stem, str(path)
    map_body = WorldBody(
        "map",
        np.array([ox, oy, 0.0]),
        quat_from_axis_angle((0.0, 0.0, 1.0), yaw),
        static=True,
        geoms=map_walls(occupied, meta["resolution"], wall_height),
    )
    world.bodies.append(map_body)
    height, width = occupied.shape
    corners = np.array([(0, 0, 0), (width, 0, 0), (0, height, 0), (width, height, 0)]) * meta["resolution"]
    world.cover_ground([map_body.pos[:2] + quat_rotate(map_body.quat, c)[:2] for c in corners])
    if spawn is not None:
        world.spawn = spawn
    return world  # a spawn pose on a wall is refused once the model is built (physics.check_spawn), as in any world


def map_walls(occupied: np.ndarray, resolution: float, height: float, name: str = "map_wall") -> list[WorldGeom]:
    """Boxes on exactly the occupied cells, in the map frame (origin at the bottom-left corner, row 0 on top)."""
    rects = np.array(cell_rectangles(occupied), dtype=float).reshape(-1, 4)
    rows = occupied.shape[0]
    r0, c0, r1, c1 = rects.T
    z = np.full(len(rects), 0.5 * height)
    centers = np.c_[0.5 * (c0 + c1) * resolution, (rows - 0.5 * (r0 + r1)) * resolution, z]
    sizes = np.c_[(c1 - c0) * resolution, (r1 - r0) * resolution, np.full(len(rects), height)]
    return box_geoms(name, centers, sizes, np.zeros(len(rects)))


def occupied_cells(grey: np.ndarray, alpha: np.ndarray | None, meta: dict[str, Any]) -> np.ndarray:
    """Which cells map_server would mark occupied (100), given grey levels in 0..255 and the YAML's fields.

    raw mode: the grey level is the occupancy in percent, values above 100 unknown.
    scale mode: transparent pixels are unknown, as in map_server.
    """
    if meta["mode"] == "raw":
        return (grey <= 100) & (grey / 100.0 > meta["occupied_thresh"])
    p = grey / 255.0 if meta["negate"] else (255.0 - grey) / 255.0
    occupied = p > meta["occupied_thresh"]
    if meta["mode"] == "scale" and alpha is not None:
        occupied &= alpha >= 255
    return occupied


def _fail(path: Path, field: str, message: str) -> WorldError:
    return WorldError(f"{path}: {field}: {message}")


def _read_yaml(path: Path) -> dict[str, Any]:
    """The YAML's fields, checked, with map_server's defaults filled in."""
    try:
        meta = yaml.safe_load(path.read_text(encoding="utf-8-sig"))
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f"line {mark.line + 1}: " if mark is not None else ""
        problem = getattr(exc, "problem", None) or str(exc).splitlines()[0]
        raise WorldError(f"{path}: {where}invalid YAML: {problem}") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise WorldError(f"{path}: cannot read: {exc}") from None
    if not isinstance(meta, dict):
        raise WorldError(f"{path}: not a map_server YAML mapping (image, resolution, origin, ...)")
    meta = {**DEFAULTS, **meta}
    if not isinstance(meta.get("image"), str) or not meta["image"].strip():
        raise _fail(path, "image", f"missing or not a file name (got {meta.get('image')!r})")
    meta["resolution"] = _number(path, meta, "resolution")
    if not meta["resolution"] > 0:
        raise _fail(path, "resolution", f"must be a positive number of metres per cell, got {meta['resolution']}")
    origin = meta.get("origin")
    if not isinstance(origin, list) or len(origin) != 3 or not all(_is_finite(v) for v in origin):
        raise _fail(path, "origin", f"must be [x, y, yaw], three finite numbers, got {origin!r}")
    meta["origin"] = tuple(finite_number(v, "origin") for v in origin)
    for key in ("occupied_thresh", "free_thresh"):
        meta[key] = _number(path, meta, key)
        if not 0.0 <= meta[key] <= 1.0:
            raise _fail(path, key, f"must lie in 0..1, got {meta[key]}")
    if meta["free_thresh"] > meta["occupied_thresh"]:
        raise _fail(path, "free_thresh", f"{meta['free_thresh']} exceeds occupied_thresh {meta['occupied_thresh']}")
    if meta["negate"] not in (0, 1):
        raise _fail(path, "negate", f"must be 0 or 1, got {meta['negate']!r}")
    if meta["mode"] not in MODES:
        raise _fail(path, "mode", f"must be one of {', '.join(MODES)}, got {meta['mode']!r}")
    return meta


def _is_finite(value: Any) -> bool:
    """Whether a YAML value is a finite number: PyYAML (YAML 1.1) reads `5e-2` as a string, where map_server
    (yaml-cpp) reads 0.05, so such a string counts (core.tables.finite_number)."""
    try:
        finite_number(value, "")
    except ConfigError:
        return False
    return True


def _number(path: Path, meta: dict[str, Any], key: str) -> float:
    """A finite number from the YAML (a string such as `5e-2` too, as map_server reads it), or a WorldError naming
    the field."""
    if key not in meta:
        raise _fail(path, key, "missing")
    if not _is_finite(meta[key]):
        raise _fail(path, key, f"must be a finite number, got {meta[key]!r}")
    return finite_number(meta[key], key)


def _read_image(path: Path, meta: dict[str, Any]) -> tuple[np.ndarray, np.ndarray | None]:
    """Grey levels (rows, cols) on map_server's 0..255 scale and the alpha channel if any; row 0 is the top. The
    image's size (MAX_IMAGE_PIXELS) and the map's extent (MAX_COORDINATE) are checked before it is decoded."""
    file = (path.parent / meta["image"]).resolve()
    if not file.is_file():
        raise _fail(path, "image", f"no such file {file}")
    try:
        with open_image(file, lambda message: _fail(path, "image", message), "map") as img:
            _check_extent(path, meta, *img.size)
            img.load()
            return _grey_levels(img)
    except (OSError, UnidentifiedImageError, ValueError) as exc:
        raise _fail(path, "image", f"cannot read {file}: {' '.join(str(exc).split())}") from None


def _check_extent(path: Path, meta: dict[str, Any], width: int, height: int) -> None:
    """WorldError unless every corner of a map of width x height cells lies within MAX_COORDINATE of the origin."""
    ox, oy, _ = meta["origin"]
    reach = math.hypot(ox, oy) + meta["resolution"] * math.hypot(width, height)
    if not reach <= MAX_COORDINATE:
        raise _fail(
            path,
            "resolution",
            f"{width} x {height} cells of {meta['resolution']:g} m from origin "
            f"[{ox:g}, {oy:g}] reach {reach:.3g} m from the world's origin, beyond the "
            f"largest world coordinate ({MAX_COORDINATE:g} m)",
        )


def _grey_levels(img: Image.Image) -> tuple[np.ndarray, np.ndarray | None]:
    """Colour channels averaged to grey, as map_server does; 16-bit images scaled down to 0..255."""
    if img.mode in SIXTEEN_BIT:
        return np.asarray(img, dtype=float) * (255.0 / 65535.0), None
    if img.mode == "P":
        img = img.convert("RGBA" if "transparency" in img.info else "RGB")
    elif img.mode not in ("L", "LA", "RGB", "RGBA"):
        img = img.convert("L")
    pixels = np.asarray(img, dtype=float)
    if pixels.ndim == 2:
        return pixels, None
    has_alpha = img.mode in ("LA", "RGBA")
    colour = pixels[..., :-1] if has_alpha else pixels
    return colour.mean(axis=2), pixels[..., -1] if has_alpha else None
