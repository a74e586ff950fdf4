"""Put a loaded `World` into an MjSpec: static geoms on the world body, free bodies, meshes, textures, lights.

Collision geoms go to group 3 (contacts and ray casts see them, the camera does not); visual geoms to
group 1 (the camera and viewer draw them, contacts ignore them) - the same split as Gazebo's.
Static geometry is laid out so that its per-step cost stays small in a map of thousands of walls: see
_add_static (bench/bench_maps.py measures it).
"""

from __future__ import annotations

import re

import mujoco
import numpy as np

from racecar_sim.core.errors import ConfigError, RacecarSimError, WorldError
from racecar_sim.core.transforms import compose, quat_to_matrix
from racecar_sim.physics.near_walls import MIN_BOXES, can_hold, hold_out
from racecar_sim.worlds.world import Light, Mesh, Scene, World, WorldBody, WorldGeom

VISUAL_GROUP = 1  # rendered by the camera and viewer
COLLISION_GROUP = 3  # hidden, but seen by contacts and ray casts
SLEEP_POLICY = mujoco.mjtSleepPolicy.mjSLEEP_NEVER  # of every moving tree: sleeping only spares the static geoms
GEOM_TYPES = {
    "box": mujoco.mjtGeom.mjGEOM_BOX,
    "cylinder": mujoco.mjtGeom.mjGEOM_CYLINDER,
    "sphere": mujoco.mjtGeom.mjGEOM_SPHERE,
    "plane": mujoco.mjtGeom.mjGEOM_PLANE,
    "capsule": mujoco.mjtGeom.mjGEOM_CAPSULE,
    "ellipsoid": mujoco.mjtGeom.mjGEOM_ELLIPSOID,
    "mesh": mujoco.mjtGeom.mjGEOM_MESH,
}
_LIGHT_TYPES = {True: mujoco.mjtLightType.mjLIGHT_DIRECTIONAL, False: mujoco.mjtLightType.mjLIGHT_POINT}
CHECKER_SIZE = 0.5  # m, side of the squares drawn on ground planes, so that the camera sees the ground move
CHECKER_SHADE = 0.85  # brightness of the darker squares relative to the plane's colour
HEADLIGHT_DIFFUSE = 0.3  # the viewer's light, at the camera: lights the faces the camera looks at
MESH_SUFFIX = "/mesh"  # a world mesh asset is its first geom's name and this


def mj_size(kind: str, size: tuple[float, ...]) -> list[float]:
    """SDF/URDF sizes (full extents, lengths) as MuJoCo's half sizes."""
    if kind == "box":
        return [0.5 * s for s in size[:3]]
    if kind in ("cylinder", "capsule"):
        return [size[0], 0.5 * size[1], 0.0]
    if kind == "sphere":
        return [size[0], 0.0, 0.0]
    if kind == "ellipsoid":
        return list(size[:3])
    if kind == "plane":
        return [0.5 * size[0], 0.5 * size[1], 1.0]  # half extents, grid spacing
    return [0.0, 0.0, 0.0]  # mesh: the mesh asset gives the size


class _Assets:
    """Mesh, texture and material assets, each added once however many geoms share it."""

    def __init__(self, spec: mujoco.MjSpec) -> None:
        self.spec = spec
        self.meshes: dict[int, str] = {}
        self.materials: dict[int, str] = {}
        self.checkers: dict[tuple[float, ...], str] = {}

    def mesh(self, mesh: Mesh, textured: bool, geom: str) -> str:
        """The mesh asset, named after the first geom that uses it (so that MuJoCo's errors name the model)."""
        key = id(mesh)
        if key not in self.meshes:
            name = f"{geom}{MESH_SUFFIX}"
            m = self.spec.add_mesh(
                name=name, uservert=mesh.vertices.ravel().tolist(), userface=mesh.faces.ravel().tolist()
            )
            m.inertia = mujoco.mjtMeshInertia.mjMESH_INERTIA_SHELL  # open surfaces (a floor sheet) are valid
            if textured and mesh.texcoord is not None:
                m.usertexcoord = mesh.texcoord.ravel().tolist()
                m.userfacetexcoord = mesh.faces.ravel().tolist()
            self.meshes[key] = name
        return self.meshes[key]

    def material(self, image: np.ndarray) -> str:
        key = id(image)
        if key not in self.materials:
            name = f"material{len(self.materials)}"
            rgba = np.ascontiguousarray(
                image[..., :4] if image.shape[-1] >= 4 else np.dstack([image, np.full(image.shape[:2], 255, np.uint8)])
            )
            # MuJoCo's texture rows run bottom-up relative to texcoord v; images are stored top-down
            rgba = np.ascontiguousarray(rgba[::-1])
            texture = self.spec.add_texture(
                name=name, type=mujoco.mjtTexture.mjTEXTURE_2D, width=rgba.shape[1], height=rgba.shape[0], nchannel=4
            )
            texture.data = rgba.tobytes()
            material = self.spec.add_material(name=name)
            material.textures[mujoco.mjtTextureRole.mjTEXROLE_RGB] = name
            self.materials[key] = name
        return self.materials[key]

    def checker(self, rgba: tuple[float, float, float, float]) -> str:
        """A material of subtle squares, CHECKER_SIZE wide in world units, in the colour `rgba`."""
        key = tuple(rgba)
        if key not in self.checkers:
            name = f"checker{len(self.checkers)}"
            self.spec.add_texture(
                name=name,
                type=mujoco.mjtTexture.mjTEXTURE_2D,
                builtin=mujoco.mjtBuiltin.mjBUILTIN_CHECKER,
                width=64,
                height=64,
                rgb1=list(rgba[:3]),
                rgb2=[CHECKER_SHADE * c for c in rgba[:3]],
            )
            # one texture tile (2 x 2 squares) spans 2 / texrepeat metres on a uniform material
            material = self.spec.add_material(
                name=name, texrepeat=[1 / CHECKER_SIZE] * 2, texuniform=True, specular=0.1
            )
            material.textures[mujoco.mjtTextureRole.mjTEXROLE_RGB] = name
            self.checkers[key] = name
        return self.checkers[key]


def _add_geom(body: mujoco.MjsBody, geom: WorldGeom, pos: np.ndarray, quat: np.ndarray, assets: _Assets) -> None:
    g = body.add_geom(
        name=geom.name, type=GEOM_TYPES[geom.kind], size=mj_size(geom.kind, geom.size), pos=list(pos), quat=list(quat)
    )
    if geom.mesh is not None:
        g.meshname = assets.mesh(geom.mesh, textured=geom.texture is not None, geom=geom.name)
    if geom.collides:
        g.group, g.contype, g.conaffinity, g.condim = COLLISION_GROUP, 1, 1, 3
        g.friction = [geom.mu, 0.0, 0.0]  # MuJoCo's sliding friction is isotropic: mu2 has no counterpart
        g.rgba = [0.5, 0.5, 0.5, 1.0]
    else:
        g.group, g.contype, g.conaffinity = VISUAL_GROUP, 0, 0
        g.rgba = list(geom.rgba)
        if geom.texture is not None:
            g.material = assets.material(geom.texture)
            g.rgba = [1.0, 1.0, 1.0, 1.0]
        elif geom.kind == "plane":
            g.material = assets.checker(geom.rgba)
            g.rgba = [1.0, 1.0, 1.0, geom.rgba[3]]


def _add_light(spec: mujoco.MjSpec, light: Light) -> None:
    mj = spec.worldbody.add_light(
        name=light.name,
        pos=list(light.pos),
        dir=list(light.direction),
        diffuse=list(light.diffuse),
        specular=list(light.specular),
        castshadow=light.cast_shadows,
        attenuation=list(light.attenuation),
    )
    if light.spot_cutoff is not None:
        mj.type = mujoco.mjtLightType.mjLIGHT_SPOT
        mj.cutoff = float(np.degrees(light.spot_cutoff))
    else:
        mj.type = _LIGHT_TYPES[light.directional]


def _scene(spec: mujoco.MjSpec, scene: Scene) -> None:
    """Ambient light, a headlight that lights what the camera faces, and the sky: a flat skybox in the world's
    background colour (MuJoCo clears to black, so without a skybox the sky would be black)."""
    light = spec.visual.headlight
    light.ambient = list(scene.ambient)  # Gazebo multiplies it by the material colour, as MuJoCo does
    light.diffuse = [HEADLIGHT_DIFFUSE] * 3
    light.specular = [0.0] * 3
    spec.add_texture(
        name="sky",
        type=mujoco.mjtTexture.mjTEXTURE_SKYBOX,
        builtin=mujoco.mjtBuiltin.mjBUILTIN_FLAT,
        width=8,
        height=8,
        rgb1=list(scene.background),
        rgb2=list(scene.background),
    )


def box_mesh(boxes: list[tuple[WorldGeom, np.ndarray, np.ndarray]]) -> Mesh:
    """One triangle mesh of boxes given as (geom, pos, quat) in a common frame. Each face has 4 corners of its own,
    counter-clockwise seen from outside, so that it keeps its own normal (flat shading, as a box geom is drawn)."""
    quads = []
    for k in range(3):
        u, v = (k + 1) % 3, (k + 2) % 3  # u x v = +k
        for side in (-0.5, 0.5):
            quad = np.zeros((4, 3))
            quad[:, k], quad[:, u], quad[:, v] = side, (-0.5, 0.5, 0.5, -0.5), (-0.5, -0.5, 0.5, 0.5)
            quads.append(quad if side > 0 else quad[::-1])
    unit = np.concatenate(quads)  # (24, 3)
    sizes = np.array([geom.size[:3] for geom, _, _ in boxes], dtype=float)
    rotations = np.array([quat_to_matrix(quat) for _, _, quat in boxes])
    centers = np.array([pos for _, pos, _ in boxes], dtype=float)
    vertices = np.einsum("nij,nkj->nki", rotations, unit[None] * sizes[:, None, :]) + centers[:, None, :]
    per_box = (np.arange(6)[:, None, None] * 4 + np.array([[0, 1, 2], [0, 2, 3]])[None]).reshape(-1, 3)
    faces = (np.arange(len(boxes))[:, None, None] * 24 + per_box[None]).reshape(-1, 3)
    return Mesh(vertices.reshape(-1, 3), faces.astype(np.int32))


def _add_static(spec: mujoco.MjSpec, wb: WorldBody, assets: _Assets, near_walls: bool) -> None:
    """A static body's geoms, on the world body: MuJoCo then places them once, never per step (builder: sleep).

    A collision plane gets a static body of its own: on the world body its unbounded box would sit in every node
    of the bounding-volume tree above it, and each wheel's midphase would walk a map's walls to its leaves. The
    untextured visual boxes of one colour are drawn as one mesh, as MuJoCo's broad phase visits every geom on
    every step; it carries the first box's name, so that deleting the model (Gazebo API) by its geoms' names
    deletes it. `near_walls`: a body of MIN_BOXES collision boxes or more (a map) keeps them as data, for
    near_walls.NearWalls to place the ones within a car's reach.
    """
    boxes: dict[tuple[float, ...], list[tuple[WorldGeom, np.ndarray, np.ndarray]]] = {}
    walls = [g for g in wb.geoms if g.kind == "box" and g.collides]
    held = near_walls and len(walls) >= MIN_BOXES and len({g.mu for g in walls}) == 1 and can_hold(spec, walls[0].mu)
    if held:
        hold_out(spec, wb.name, walls[0].mu, [(*compose(wb.pos, wb.quat, g.pos, g.quat), g.size) for g in walls])
    for geom in wb.geoms:
        pos, quat = compose(wb.pos, wb.quat, geom.pos, geom.quat)
        if held and geom.kind == "box" and geom.collides:
            continue
        if geom.kind == "plane" and geom.collides:
            body = spec.worldbody.add_body(pos=list(pos), quat=list(quat))  # unnamed: a respawned model reuses none
            body.fuse = False
            _add_geom(body, geom, np.zeros(3), np.array([1.0, 0.0, 0.0, 0.0]), assets)
        elif geom.kind == "box" and not geom.collides and geom.texture is None:
            boxes.setdefault(tuple(geom.rgba), []).append((geom, pos, quat))
        else:
            _add_geom(spec.worldbody, geom, pos, quat, assets)
    for group in boxes.values():
        if len(group) == 1:
            _add_geom(spec.worldbody, *group[0], assets)
            continue
        first = group[0][0]
        merged = WorldGeom(
            first.name,
            "mesh",
            (),
            np.zeros(3),
            np.array([1.0, 0.0, 0.0, 0.0]),
            collides=False,
            rgba=first.rgba,
            mesh=box_mesh(group),
        )
        _add_geom(spec.worldbody, merged, merged.pos, merged.quat, assets)


def add_world(spec: mujoco.MjSpec, world: World, near_walls: bool = False) -> None:
    """Add every body, geom and light of `world` to `spec`; `near_walls`: a map's many wall boxes as data (see
    near_walls.py). WorldError for a name given twice (MuJoCo takes each once)."""
    _check_names(world)
    assets = _Assets(spec)
    for wb in world.bodies:
        if wb.static:
            _add_static(spec, wb, assets, near_walls)
            continue
        body = spec.worldbody.add_body(
            name=wb.name,
            pos=list(wb.pos),
            quat=list(wb.quat),
            mass=wb.mass,
            ipos=list(wb.com),
            fullinertia=list(wb.inertia),
            explicitinertial=True,
        )
        body.add_freejoint(name=f"{wb.name}::free")
        body.sleep = SLEEP_POLICY
        for geom in wb.geoms:
            _add_geom(body, geom, geom.pos, geom.quat, assets)
    for light in world.lights:
        _add_light(spec, light)
    _scene(spec, world.scene)


def _check_names(world: World) -> None:
    """A WorldError naming the world and the name if two free bodies, two geoms or two lights share a name."""
    for kind, names in (
        ("models' links", [body.name for body in world.bodies if not body.static]),
        ("geoms", [geom.name for _, geom in world.geoms()]),
        ("lights", [light.name for light in world.lights]),
    ):
        seen: set[str] = set()
        for name in names:
            if name in seen:
                raise WorldError(f"{world.label}: two {kind} named '{name}' (MuJoCo takes each name once)")
            seen.add(name)


def world_element(world: World, element: str) -> str | None:
    """The name of the world's body, geom or light that the MuJoCo element `element` (a name in one of MuJoCo's
    messages) was built from, or None if the world built none of that name (a car's)."""
    name = element.removesuffix(MESH_SUFFIX)
    names = {body.name for body in world.bodies} | {geom.name for _, geom in world.geoms()}
    return name if name in names or name in {light.name for light in world.lights} else None


def mujoco_rejected(exc: Exception, world: World, xacro: object) -> RacecarSimError:
    """MuJoCo's compile error (`Error: ...`, `Element name 'x', id n`, maybe a line more) as one line that blames
    what the element was built from: the world file and its model (WorldError), else the car's xacro (ConfigError)."""
    lines = [line.strip() for line in str(exc).splitlines() if line.strip()]
    reason = (lines[0] if lines else "no reason given").removeprefix("Error:").strip()
    found = re.search(r"Element name '([^']*)'", str(exc))
    element = found[1] if found else ""
    owner = world_element(world, element) if element else None
    if owner is not None:
        return WorldError(f"{world.label}: {owner}: MuJoCo cannot take it: {reason}")
    where = f" ({element})" if element else ""
    return ConfigError(f"MuJoCo rejected the model built from {xacro}{where} in world {world.label}: {reason}")
