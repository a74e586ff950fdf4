"""Frustum culling of a posed MjvScene: the geoms that cannot reach the camera's image are taken out before drawing.

mjr_render draws every geom of the scene, and on Mesa's llvmpipe each draw costs its state changes and vertex work
whether or not a pixel of it lands in the image (about 9 us a geom: a quarter of a walker frame's drawing goes to
the car under the camera and the walls behind it). With shadows and reflections off (offscreen.py), a geom's only
effect on the image is its own fragments: a geom whose bounding sphere lies wholly outside the view frustum has
none, and leaving it out changes no pixel. Nor has a sphere, ellipsoid, cylinder or box whose own box (its size in
its frame) lies wholly outside one of the frustum's planes, the near plane included: that test leaves out the car's
own parts around the camera, whose spheres reach into the view while the parts do not (17 geoms drawn a walker
frame become 13). The geoms kept are drawn in their order, so depth ties between them
resolve as before: the image is MuJoCo's, bit for bit.

The bindings give each MjvGeom field separately; taking out geoms field by field would cost more Python than the
drawing saves. So the scene's geom records are viewed as raw bytes, and the kept ones are moved to the front in one
compiled pass (frustum_kernel.py: 4 us a frame). The record layout (its size and where `pos` and `modelrbound` lie
in it) is found once, by writing distinct values through the bindings into a probe scene and finding them in its
memory; where it cannot be found (another MuJoCo's layout), nothing is culled.
"""

from __future__ import annotations

import ctypes
import functools
from typing import NamedTuple

import mujoco
import numpy as np

MARGIN = 1.25
"""The frustum's half-extents are widened by this factor (and bounding spheres by CLEARANCE) before testing: the test
is conservative, culling only geoms well outside the image."""
CLEARANCE = 0.01  # m


def _boxed_types() -> np.ndarray:
    """By geom type (MjvGeom.type): 1 where all that mjr_render draws of the geom lies in the box of half-extents
    `size` in its frame (pos, mat): it draws a unit sphere, cylinder or cube scaled by size; 0 where no such box is
    known (planes, capsules, meshes, decorations): the sphere test alone decides."""
    boxed = np.zeros(1 + max(int(t) for t in mujoco.mjtGeom.__members__.values()), np.uint8)
    for name in ("mjGEOM_SPHERE", "mjGEOM_ELLIPSOID", "mjGEOM_CYLINDER", "mjGEOM_BOX"):
        boxed[int(getattr(mujoco.mjtGeom, name))] = 1
    return boxed


_BOXED = _boxed_types()


class FrustumCuller:
    """Takes the geoms that cannot appear in the image out of a posed `scene` drawn at width x height (cull())."""

    def __init__(self, scene: mujoco.MjvScene, width: int, height: int) -> None:
        self.scene, self.aspect = scene, width / height
        layout = _record_layout()
        self._raw: np.ndarray | None = None
        self._eyes: tuple[mujoco.MjvGLCamera, ...] | None = None
        self._views: tuple[np.ndarray, ...] = ()  # the eyes' positions, forward and up
        if layout is None or scene.maxgeom < 2:
            return
        size = layout.size
        base = _address(scene.geoms[0].pos) - layout.pos
        memory = (ctypes.c_uint8 * (size * scene.maxgeom)).from_address(base)
        self._raw = np.ctypeslib.as_array(memory).reshape(scene.maxgeom, size)
        self._pos = np.ndarray((scene.maxgeom, 3), np.float32, memory, layout.pos, (size, 4))
        self._rbound = np.ndarray((scene.maxgeom,), np.float32, memory, layout.rbound, (size,))
        self._type = np.ndarray((scene.maxgeom,), np.int32, memory, layout.type, (size,))
        self._half = np.ndarray((scene.maxgeom, 3), np.float32, memory, layout.half, (size, 4))
        self._mat = np.ndarray((scene.maxgeom, 9), np.float32, memory, layout.mat, (size, 4))
        self._load_kernel(self._raw)

    def _load_kernel(self, raw: np.ndarray) -> None:
        """Load the compiled cull (numba's cache) now, as the camera starts, not with its first frame in the run: a
        call on no geoms (n = 0: nothing read or moved), with the argument types of cull()'s."""
        from racecar_sim.render.frustum_kernel import cull_records

        self._kernel = cull_records  # kept: an import at every frame costs microseconds of import machinery
        eye, forward, up = np.zeros(3, np.float32), np.array([1, 0, 0], np.float32), np.array([0, 0, 1], np.float32)
        cull_records(
            raw, self._pos, self._rbound, self._type, self._half, self._mat, _BOXED, 0,
            eye, eye, forward, up, 0.1, 0.0, -0.1, 0.1, 1.0, 0.0, 0.0,
        )  # fmt: skip

    @property
    def active(self) -> bool:
        """Whether this MuJoCo's geom records could be read (otherwise cull() keeps every geom)."""
        return self._raw is not None

    def cull(self) -> int:
        """Move the geoms whose bounding sphere meets the view frustum to the front, in order, and drop the rest;
        returns how many were dropped. Geoms without a bounding radius (planes, decorations) are always kept."""
        scene, raw = self.scene, self._raw
        n = scene.ngeom
        if raw is None or n == 0:
            return 0
        if self._eyes is None:  # the cameras' views into the scene: read live at every call
            self._eyes = scene.camera
            self._views = (self._eyes[0].pos, self._eyes[1].pos, self._eyes[0].forward, self._eyes[0].up)
        left = self._eyes[0]
        if left.orthographic:
            return 0
        kept = self._kernel(
            raw,
            self._pos,
            self._rbound,
            self._type,
            self._half,
            self._mat,
            _BOXED,
            n,
            self._views[0],
            self._views[1],
            self._views[2],
            self._views[3],
            left.frustum_near,
            left.frustum_center,
            left.frustum_bottom,
            left.frustum_top,
            self.aspect,
            MARGIN,
            CLEARANCE,
        )
        scene.ngeom = kept
        return n - kept


def _address(array: np.ndarray) -> int:
    return int(array.ctypes.data)


class RecordLayout(NamedTuple):
    """Where an MjvGeom's fields lie in its record, in bytes: the record's size and the offsets of `pos` (3 float32),
    `modelrbound` (float32), `type` (int32), `size` (3 float32) and `mat` (9 float32, row-major)."""

    size: int
    pos: int
    rbound: int
    type: int
    half: int
    mat: int


@functools.cache
def _record_layout() -> RecordLayout | None:
    """The layout of an MjvGeom record in this MuJoCo, or None if not found.

    Each field of the middle geom of a 3-geom probe scene is changed through the bindings, and the bytes that change
    are its place; the record starts at the lowest of them (a C struct's first member is at offset 0)."""
    model = mujoco.MjModel.from_xml_string("<mujoco><worldbody><geom size='1'/></worldbody></mujoco>")
    scene = mujoco.MjvScene(model, 3)
    geoms = scene.geoms
    size = _address(geoms[1].pos) - _address(geoms[0].pos)
    if size <= 0 or _address(geoms[2].pos) - _address(geoms[1].pos) != size:
        return None
    for geom in geoms:  # defined values to change (a new scene's records are uninitialised memory)
        mujoco.mjv_initGeom(geom, mujoco.mjtGeom.mjGEOM_BOX, np.ones(3), np.zeros(3), np.eye(3).ravel(), np.ones(4))
    anchor = _address(geoms[1].pos)  # [anchor - size, anchor + size) lies within the three records
    window = np.ctypeslib.as_array((ctypes.c_uint8 * (2 * size)).from_address(anchor - size))
    places: dict[str, tuple[int, int]] = {}
    for name in dir(geoms[1]):
        value = getattr(geoms[1], name)
        if name.startswith("_") or callable(value):
            continue
        before = window.copy()
        if not _change(geoms[1], name, value):
            return None
        changed = np.flatnonzero(window != before)
        if changed.size == 0:
            return None
        places[name] = (int(changed[0]) - size, int(changed[-1]) - size)  # relative to pos of geom 1
    if not {"pos", "modelrbound", "type", "size", "mat"} <= places.keys():
        return None
    first = min(lo for lo, _ in places.values()) // 4 * 4  # the record starts with a 4-byte member (int type)
    last = max(hi for _, hi in places.values())
    if last - first >= size:
        return None

    def at(name: str) -> int:  # places are relative to pos; a number's first changed byte need not be its first
        return places[name][0] // 4 * 4 - first

    layout = RecordLayout(size, -first, at("modelrbound"), at("type"), at("size"), at("mat"))
    records = np.ctypeslib.as_array((ctypes.c_uint8 * (3 * size)).from_address(anchor - layout.pos - size))
    for index, geom in enumerate(geoms):  # read back where the layout says, what the bindings wrote
        geom.pos[:] = (1.5 + index, -2.5, 3.25)
        geom.modelrbound = 7.125 + index
        geom.type = index + 4
        geom.size[:] = (0.5 + index, 1.75, -3.5)
        geom.mat[...] = (np.arange(9) + 0.25 * index).reshape(geom.mat.shape)
        record = records[index * size : (index + 1) * size]
        if not (
            np.array_equal(_floats(record, layout.pos, 3), geom.pos)
            and _floats(record, layout.rbound, 1)[0] == np.float32(geom.modelrbound)
            and record[layout.type : layout.type + 4].copy().view(np.int32)[0] == geom.type
            and np.array_equal(_floats(record, layout.half, 3), geom.size)
            and np.array_equal(_floats(record, layout.mat, 9), geom.mat.ravel())
        ):
            return None
    return layout


def _floats(record: np.ndarray, at: int, count: int) -> np.ndarray:
    return record[at : at + 4 * count].copy().view(np.float32)


def _change(geom: mujoco.MjvGeom, name: str, value: object) -> bool:
    """Set field `name` of `geom` to a value other than `value`, through the bindings; False if it cannot be."""
    try:
        if isinstance(value, np.ndarray):
            value[...] = value + 1
        elif isinstance(value, bool):
            setattr(geom, name, not value)
        elif isinstance(value, (int, float)):
            setattr(geom, name, value + 3)
        elif isinstance(value, str):
            setattr(geom, name, value + "x")
        else:
            return False
    except (TypeError, ValueError, AttributeError):
        return False
    return True
