"""Load the SDF subset (1.4 - 1.9) that Gazebo worlds use into a `World`.

Read: <world> with <physics>, <gravity>, <scene>, <light>, <model> and <include> of model:// models (built-in
sun and ground_plane, then --model-path, GAZEBO_MODEL_PATH, GZ_SIM_RESOURCE_PATH, and the packages on
ROS_PACKAGE_PATH as gazebo_ros adds them: their gazebo_model_path exports and the folders holding them); an
include's <pose>, <name> and <static> override the model's own. <model> with <static>, <pose>, nested
<model>/<include>, <link> with <pose>, <inertial> and <collision>/<visual> (box, cylinder, sphere, plane, capsule,
ellipsoid, mesh), <surface><friction><ode><mu>/<mu2>, <material> (Gazebo script names, colours, <pbr> albedo_map).
Anything else gets a warning naming the element and where it is; nothing is dropped silently.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np

from racecar_sim.core.errors import WorldError
from racecar_sim.core.transforms import compose, quat_to_matrix
from racecar_sim.worlds.sdf_parts import (
    SdfContext,
    flag,
    number,
    numbers,
    pose,
    pose_or_identity,
    resolve_uri,
    rgba_of,
    shapes,
)
from racecar_sim.worlds.world import Light, Physics, Scene, World, WorldBody

Pose = tuple[np.ndarray, np.ndarray]
_WORLD_KNOWN = {"include", "model", "light", "physics", "gravity", "scene"}
_MODEL_KNOWN = {"static", "pose", "link", "include", "model", "allow_auto_disable"}
_LINK_KNOWN = {"pose", "inertial", "collision", "visual", "self_collide", "kinematic", "gravity"}
_COLLISION_KNOWN = {"geometry", "pose", "surface", "max_contacts", "laser_retro"}
_VISUAL_KNOWN = {"geometry", "pose", "material", "cast_shadows", "transparency", "meta"}
_INCLUDE_KNOWN = {"uri", "name", "pose", "static"}
_LIGHT_KNOWN = {"pose", "diffuse", "specular", "attenuation", "direction", "cast_shadows", "spot", "intensity"}
_SCENE_KNOWN = {"ambient", "background", "shadows", "grid", "origin_visual"}
# ODE tuning with no MuJoCo counterpart, and Gazebo's defaults for them: a world that changes one is told so.
_ODE_DEFAULTS: dict[str, str | float] = {
    "solver/type": "quick",
    "solver/sor": 1.3,
    "solver/min_step_size": 0.0001,
    "solver/precon_iters": 0,
    "solver/use_dynamic_moi_rescaling": "false",
    "solver/friction_model": "pyramid_model",
    "solver/island_threads": 0,
    "solver/thread_position_correction": 0,
    "constraints/cfm": 0.0,
    "constraints/erp": 0.2,
    "constraints/contact_max_correcting_vel": 100.0,
    "constraints/contact_surface_layer": 0.001,
}
MAX_NESTING = 64  # models within models (nested <model>s and <include>s)
_PHYSICS_KNOWN = {
    "max_step_size",
    "real_time_factor",
    "real_time_update_rate",
    "gravity",
    "ode",
    "max_contacts",
    "magnetic_field",
}


def _parse(path: Path) -> ET.Element:
    try:
        root = ET.parse(path).getroot()
    except ET.ParseError as exc:
        raise WorldError(f"{path}: malformed XML: {exc}") from None
    except OSError as exc:
        raise WorldError(f"{path}: cannot read: {exc.strerror}") from None
    if root.tag != "sdf":
        raise WorldError(f"{path}: root element is <{root.tag}>, expected <sdf>")
    return root


def _inertial(el: ET.Element, body: WorldBody, ctx: SdfContext, where: str) -> None:
    ctx.warn_unknown(el, {"mass", "inertia", "pose"}, f"{where} <inertial>")
    body.mass = number(el, "mass", 1.0, ctx, f"{where} <inertial>")
    if not body.mass > 0:
        raise ctx.error(f"{where} <inertial><mass> must be positive, got {body.mass:g}")
    values = dict.fromkeys(("ixy", "ixz", "iyz"), 0.0) | dict.fromkeys(("ixx", "iyy", "izz"), 1.0)
    inertia = el.find("inertia")
    if inertia is not None:
        values = {k: number(inertia, k, v, ctx, f"{where} <inertia>") for k, v in values.items()}
    tensor = np.array(
        [
            [values["ixx"], values["ixy"], values["ixz"]],
            [values["ixy"], values["iyy"], values["iyz"]],
            [values["ixz"], values["iyz"], values["izz"]],
        ]
    )
    com, frame = pose_or_identity(el, ctx, f"{where} <inertial>")
    rot = quat_to_matrix(frame)
    tensor = rot @ tensor @ rot.T  # into the link frame, where MuJoCo's fullinertia is given
    a, b, c = np.linalg.eigvalsh(tensor)  # the principal moments, ascending
    given = ", ".join(f"{k} {values[k]:g}" for k in ("ixx", "iyy", "izz", "ixy", "ixz", "iyz"))
    if not a > 0:
        raise ctx.error(
            f"{where} <inertial><inertia>: a body's inertia must be positive definite, but its principal "
            f"moments are {a:g}, {b:g}, {c:g} ({given})"
        )
    if a + b < c * (1.0 - 1e-9):
        raise ctx.error(
            f"{where} <inertial><inertia>: principal moments {a:g}, {b:g}, {c:g} break the triangle "
            f"inequality (the two smaller must add up to the largest, as for any rigid body) ({given})"
        )
    body.com = com
    body.inertia = (tensor[0, 0], tensor[1, 1], tensor[2, 2], tensor[0, 1], tensor[0, 2], tensor[1, 2])


def _link(el: ET.Element, model: str, static: bool, model_pose: Pose, ctx: SdfContext) -> WorldBody:
    name = f"{model}::{el.get('name', 'link')}"
    ctx.claim(
        ("link", name),
        f"model '{model}' has two links named '{el.get('name', 'link')}' (MuJoCo and Gazebo take each name once)",
    )
    ctx.warn_unknown(el, _LINK_KNOWN, f"link {name}")
    if not flag(el, "gravity", True):
        ctx.warn("gravity>false</gravity", f"link {name}", "is not supported: gravity acts on every body")
    link_pos, link_quat = compose(*model_pose, *pose_or_identity(el, ctx, name))
    body = WorldBody(name, link_pos, link_quat, static=static or flag(el, "kinematic", False))
    inertial = el.find("inertial")
    if inertial is not None:
        _inertial(inertial, body, ctx, name)
    for shape in el.findall("collision"):
        where = f"{name}/{shape.get('name', 'collision')}"
        _claim_shape(ctx, name, where)
        ctx.warn_unknown(shape, _COLLISION_KNOWN, where)
        mu = number(shape, "surface/friction/ode/mu", 1.0, ctx, f"{where} <surface>")
        mu2 = number(shape, "surface/friction/ode/mu2", mu, ctx, f"{where} <surface>")
        if mu < 0 or mu2 < 0:
            raise ctx.error(f"{where} <surface><friction>: mu and mu2 must not be negative")
        surface = shape.find("surface")
        if surface is not None:
            ctx.warn_unknown(surface, {"friction"}, f"{where} <surface>")
        for geom in shapes(shape, True, ctx, where, static=body.static):
            geom.mu, geom.mu2 = mu, mu2
            body.geoms.append(geom)
    for shape in el.findall("visual"):
        where = f"{name}/{shape.get('name', 'visual')}"
        _claim_shape(ctx, name, where)
        ctx.warn_unknown(shape, _VISUAL_KNOWN, where)
        rgba = rgba_of(shape.find("material"), ctx, where)
        for geom in shapes(shape, False, ctx, where):
            if geom.mesh is None or shape.find("material") is not None:
                geom.rgba = rgba
            body.geoms.append(geom)
    return body


def _claim_shape(ctx: SdfContext, link: str, where: str) -> None:
    """Take the name of a <collision> or <visual>: both become MuJoCo geoms, which take each name once."""
    ctx.claim(
        ("shape", where),
        f"link '{link}' has two <collision>/<visual> elements named "
        f"'{where.rpartition('/')[2]}' (each needs a name of its own)",
    )


def _model(el: ET.Element, world: World, ctx: SdfContext, placed: Pose, name: str, static: bool | None = None) -> None:
    """Add a <model> whose frame is at `placed` in the world."""
    if name.count("::") >= MAX_NESTING:
        raise ctx.error(f"model {name.split('::')[0]}: models nested more than {MAX_NESTING} deep")
    ctx.claim(
        ("model", name),
        f"two models named '{name}': Gazebo refuses a repeated model name too (give each "
        "its own name, an <include> its own <name>)",
    )
    ctx.warn_unknown(el, _MODEL_KNOWN, f"model {name}")
    static = flag(el, "static", False) if static is None else static
    for child in el:
        if child.tag == "link":
            world.bodies.append(_link(child, name, static, placed, ctx))
        elif child.tag == "include":
            _include(child, world, ctx, placed, f"{name}::")
        elif child.tag == "model":
            inner = compose(*placed, *pose_or_identity(child, ctx, f"model {name}"))
            _model(child, world, ctx, inner, f"{name}::{child.get('name', 'model')}", static or None)


def _light(el: ET.Element, ctx: SdfContext, placed: Pose | None = None) -> Light:
    """A <light> at its own pose, or at `placed` (an include's pose) when given."""
    name = el.get("name", "light")
    where = f"light {name}"
    ctx.warn_unknown(el, _LIGHT_KNOWN, where)
    pos, quat = placed if placed is not None else pose_or_identity(el, ctx, where)
    kind = el.get("type", "point")
    if kind not in ("point", "directional", "spot"):
        raise ctx.error(f"{where}: type '{kind}' is not point, directional or spot")
    direction = quat_to_matrix(quat) @ np.array(
        numbers(el.findtext("direction") or "0 0 -1", 3, ctx, f"{where} <direction>")
    )
    diffuse = numbers(el.findtext("diffuse") or "1 1 1 1", 4, ctx, f"{where} <diffuse>")
    specular = numbers(el.findtext("specular") or "0.1 0.1 0.1 1", 4, ctx, f"{where} <specular>")
    light = Light(
        name, kind == "directional", pos, direction, diffuse[:3], flag(el, "cast_shadows", False), specular[:3]
    )
    attenuation = el.find("attenuation")
    if attenuation is not None:
        ctx.warn_unknown(attenuation, {"constant", "linear", "quadratic", "range"}, f"{where} <attenuation>")
        constant, linear, quadratic = (
            number(attenuation, k, d, ctx, f"{where} <attenuation>")
            for k, d in (("constant", 1.0), ("linear", 0.0), ("quadratic", 0.0))
        )
        light.attenuation = (constant, linear, quadratic)
    if kind == "spot":
        light.spot_cutoff = number(el, "spot/outer_angle", 1.0, ctx, f"{where} <spot>")
    return light


def _include(el: ET.Element, world: World, ctx: SdfContext, parent: Pose | None = None, prefix: str = "") -> None:
    uri = (el.findtext("uri") or "").strip()
    if not uri:
        raise ctx.error("<include> without a <uri>")
    ctx.warn_unknown(el, _INCLUDE_KNOWN, f"include {uri}")
    folder = resolve_uri(uri, ctx, "<include>")
    path = folder if folder.is_file() else folder / "model.sdf"
    if not path.is_file():
        raise ctx.error(f"<include> {uri}: {path} does not exist")
    inner = ctx.inside(path, uri)
    root = _parse(path)
    model, light = root.find("model"), root.find("light")
    target = model if model is not None else light
    if target is None:
        raise ctx.error(f"<include> {uri}: {path} holds neither a <model> nor a <light>")
    # An include's pose replaces the model's own pose (Gazebo does the same); both are relative to the parent.
    placed = pose(el, ctx, f"include {uri}") or pose_or_identity(target, inner, f"{target.tag} {uri}")
    if parent is not None:
        placed = compose(*parent, *placed)
    if model is not None:
        name = prefix + ((el.findtext("name") or "").strip() or model.get("name", "model"))
        static = el.findtext("static")
        _model(model, world, inner, placed, name, None if static is None else flag(el, "static", False))
    elif light is not None:  # the target
        world.lights.append(_light(light, inner, placed))


def _physics(el: ET.Element, physics: Physics, ctx: SdfContext) -> None:
    ctx.warn_unknown(el, _PHYSICS_KNOWN, "<physics>")
    if el.get("type", "ode") != "ode":
        ctx.warn(f"physics type='{el.get('type')}'", "", "is not used: MuJoCo is the physics engine")
    step = el.findtext("max_step_size")
    if step is not None and step.strip():
        physics.max_step_size = numbers(step, 1, ctx, "<physics><max_step_size>")[0]
        if physics.max_step_size <= 0:
            raise ctx.error(f"<physics><max_step_size> must be positive, got {step.strip()}")
    physics.real_time_factor = number(el, "real_time_factor", 1.0, ctx, "<physics>")
    iters = el.findtext("ode/solver/iters")
    if iters is not None and iters.strip():
        physics.iterations = int(numbers(iters, 1, ctx, "<physics><ode><solver><iters>")[0])
        if physics.iterations < 1:
            raise ctx.error(f"<physics><ode><solver><iters> must be at least 1, got {iters.strip()}")
    for key, default in _ODE_DEFAULTS.items():
        text = el.findtext(f"ode/{key}")
        if text is None or not text.strip():
            continue
        same = text.strip() == default if isinstance(default, str) else abs(float(text) - default) < 1e-12
        if not same:
            ctx.warn(
                f"ode/{key}>{text.strip()}</{key.split('/')[-1]}",
                "<physics>",
                "is an ODE setting with no MuJoCo counterpart and was ignored",
            )
    gravity = el.findtext("gravity")
    if gravity is not None and gravity.strip():
        physics.gravity = numbers(gravity, 3, ctx, "<physics><gravity>")


def _scene(el: ET.Element, scene: Scene, ctx: SdfContext) -> None:
    ctx.warn_unknown(el, _SCENE_KNOWN, "<scene>")
    for tag in ("ambient", "background"):
        text = el.findtext(tag)
        if text and text.strip():
            values = numbers(text, len(text.split()), ctx, f"<scene><{tag}>")
            if len(values) not in (3, 4):
                raise ctx.error(f"<scene><{tag}>: '{text.strip()}' is not a colour (3 or 4 numbers)")
            setattr(scene, tag, values[:3])
    scene.shadows = flag(el, "shadows", scene.shadows)


def load_sdf(path: str | Path, model_path: list[Path] | None = None) -> World:
    """Load an SDF world file; raises WorldError with the file and element on bad input."""
    path = Path(path)
    root = _parse(path)
    world_el = root.find("world")
    if world_el is None:
        raise WorldError(f"{path}: no <world> element")
    ctx = SdfContext(path, [Path(p) for p in (model_path or [])])
    world = World(world_el.get("name", path.stem), str(path))
    ctx.warn_unknown(world_el, _WORLD_KNOWN, f"world {world.name}")
    for el in world_el:
        if el.tag == "include":
            _include(el, world, ctx)
        elif el.tag == "model":
            name = el.get("name", "model")
            _model(el, world, ctx, pose_or_identity(el, ctx, f"model {name}"), name)
        elif el.tag == "light":
            world.lights.append(_light(el, ctx))
        elif el.tag == "physics":
            _physics(el, world.physics, ctx)
        elif el.tag == "gravity":
            world.physics.gravity = numbers(el.text, 3, ctx, "<gravity>")
        elif el.tag == "scene":
            _scene(el, world.scene, ctx)
    return world


__all__ = ["load_sdf", "resolve_uri"]
