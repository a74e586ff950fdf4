"""Load the SDF subset Gazebo worlds use into a `World`.

Supported now: <world> with <physics> (max_step_size, gravity, ode/solver/iters), <include> of model://
models (the built-in ones beside this module, then GAZEBO_MODEL_PATH / GZ_SIM_RESOURCE_PATH) with pose and
name overrides, <model> with <static>, <pose>, <link> (<pose>, <inertial>), <collision>/<visual> with box,
cylinder, sphere and plane geometry, <surface><friction><ode><mu>/<mu2>, material colours, <light>.
Anything else gets a warning naming the element; it is never dropped silently.
"""

from __future__ import annotations

import os
import warnings
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np

from racecar_sim.core.errors import WorldError
from racecar_sim.core.transforms import compose, quat_from_rpy
from racecar_sim.worlds.materials import gazebo_material_rgba
from racecar_sim.worlds.world import Light, Physics, World, WorldBody, WorldGeom

BUILTIN_MODELS = Path(__file__).parent / "data" / "models"
_IGNORED = {"gui", "scene", "audio", "plugin", "gravity", "magnetic_field", "atmosphere", "state", "spherical_coordinates",
            "wind", "self_collide", "enable_wind", "kinematic"}


class _Context:
    def __init__(self, source: Path, model_path: list[Path]):
        self.source = source
        self.model_path = model_path

    def error(self, message: str) -> WorldError:
        return WorldError(f"{self.source}: {message}")

    def warn(self, element: str, where: str = "") -> None:
        place = f" in {where}" if where else ""
        warnings.warn(f"{self.source}: <{element}>{place} is not supported and was ignored", stacklevel=3)


def _numbers(text: str | None, n: int, ctx: _Context, where: str) -> tuple[float, ...]:
    try:
        values = tuple(float(v) for v in (text or "").split())
    except ValueError:
        raise ctx.error(f"{where}: '{text}' is not {n} numbers") from None
    if len(values) != n or not all(np.isfinite(values)):
        raise ctx.error(f"{where}: '{text}' is not {n} finite numbers")
    return values


def _pose(el: ET.Element, ctx: _Context, where: str) -> tuple[np.ndarray, np.ndarray]:
    pose_el = el.find("pose")
    if pose_el is None or not (pose_el.text or "").strip():
        return np.zeros(3), np.array([1.0, 0, 0, 0])
    v = _numbers(pose_el.text, 6, ctx, f"{where} <pose>")
    return np.array(v[:3]), quat_from_rpy(v[3:])


def _geometry(el: ET.Element | None, ctx: _Context, where: str) -> tuple[str, tuple[float, ...]] | None:
    if el is None or len(el) == 0:
        raise ctx.error(f"{where}: <geometry> is missing or empty")
    g = el[0]
    if g.tag == "box":
        return "box", _numbers(g.findtext("size"), 3, ctx, f"{where} box <size>")
    if g.tag == "cylinder":
        return "cylinder", (_numbers(g.findtext("radius"), 1, ctx, f"{where} <radius>")[0],
                            _numbers(g.findtext("length"), 1, ctx, f"{where} <length>")[0])
    if g.tag == "sphere":
        return "sphere", _numbers(g.findtext("radius"), 1, ctx, f"{where} <radius>")
    if g.tag == "plane":
        normal = _numbers(g.findtext("normal") or "0 0 1", 3, ctx, f"{where} plane <normal>")
        if normal != (0.0, 0.0, 1.0):
            ctx.warn(f"normal>{' '.join(f'{v:g}' for v in normal)}</normal", f"{where} (only 0 0 1 planes)")
        return "plane", _numbers(g.findtext("size") or "100 100", 2, ctx, f"{where} plane <size>")
    ctx.warn(g.tag, f"{where} <geometry>")
    return None


def _rgba(el: ET.Element | None, ctx: _Context) -> tuple[float, float, float, float]:
    if el is None:
        return (0.7, 0.7, 0.7, 1.0)
    script_name = el.findtext("script/name")
    if script_name:
        return gazebo_material_rgba(script_name.strip())
    for tag in ("diffuse", "ambient"):
        text = el.findtext(tag)
        if text:
            return _numbers(text, 4, ctx, f"material <{tag}>")  # type: ignore[return-value]
    return (0.7, 0.7, 0.7, 1.0)


def _link(el: ET.Element, model: str, static: bool, pos: np.ndarray, quat: np.ndarray, ctx: _Context) -> WorldBody:
    name = f"{model}::{el.get('name', 'link')}"
    link_pos, link_quat = compose(pos, quat, *_pose(el, ctx, name))
    body = WorldBody(name, link_pos, link_quat, static=static)
    inertial = el.find("inertial")
    if inertial is not None:
        body.mass = _numbers(inertial.findtext("mass") or "1", 1, ctx, f"{name} <mass>")[0]
        inertia = inertial.find("inertia")
        if inertia is not None:
            body.inertia = tuple(_numbers(inertia.findtext(k) or "1", 1, ctx, f"{name} <{k}>")[0]
                                 for k in ("ixx", "iyy", "izz"))  # type: ignore[assignment]
    for kind in ("collision", "visual"):
        for shape in el.findall(kind):
            where = f"{name}/{shape.get('name', kind)}"
            geometry = _geometry(shape.find("geometry"), ctx, where)
            if geometry is None:
                continue
            gpos, gquat = _pose(shape, ctx, where)
            geom = WorldGeom(where, geometry[0], geometry[1], gpos, gquat, collides=kind == "collision")
            if kind == "collision":
                mu = shape.findtext("surface/friction/ode/mu")
                mu2 = shape.findtext("surface/friction/ode/mu2")
                geom.mu = _numbers(mu, 1, ctx, f"{where} <mu>")[0] if mu else 1.0
                geom.mu2 = _numbers(mu2, 1, ctx, f"{where} <mu2>")[0] if mu2 else 1.0
            else:
                geom.rgba = _rgba(shape.find("material"), ctx)
            body.geoms.append(geom)
    for child in el:
        if child.tag not in ("pose", "inertial", "collision", "visual", "self_collide", "kinematic", "gravity"):
            ctx.warn(child.tag, f"link {name}")
    return body


def _model(el: ET.Element, world: World, ctx: _Context, pose_override=None, name_override=None,
           static_override=None) -> None:
    name = name_override or el.get("name", "model")
    pos, quat = pose_override if pose_override is not None else _pose(el, ctx, f"model {name}")
    static = static_override if static_override is not None else (el.findtext("static") or "false").strip() in ("true", "1")
    for child in el:
        if child.tag == "link":
            world.bodies.append(_link(child, name, static, pos, quat, ctx))
        elif child.tag == "include":
            _include(child, world, ctx, parent=(pos, quat))
        elif child.tag == "model":
            inner_pos, inner_quat = compose(pos, quat, *_pose(child, ctx, f"model {name}"))
            _model(child, world, ctx, (inner_pos, inner_quat), f"{name}::{child.get('name')}", static)
        elif child.tag not in ("static", "pose") and child.tag not in _IGNORED:
            ctx.warn(child.tag, f"model {name}")


def _light(el: ET.Element, ctx: _Context) -> Light:
    name = el.get("name", "light")
    pos, _ = _pose(el, ctx, f"light {name}")
    direction = np.array(_numbers(el.findtext("direction") or "0 0 -1", 3, ctx, f"light {name} <direction>"))
    diffuse = _numbers(el.findtext("diffuse") or "0.8 0.8 0.8 1", 4, ctx, f"light {name} <diffuse>")
    shadows = (el.findtext("cast_shadows") or "false").strip() in ("true", "1")
    return Light(name, el.get("type") == "directional", pos, direction, diffuse[:3], shadows)  # type: ignore[arg-type]


def _find_model(uri: str, ctx: _Context) -> Path:
    if not uri.startswith("model://"):
        raise ctx.error(f"<include><uri>{uri}</uri>: only model:// URIs are supported")
    name = uri[len("model://"):].strip("/")
    search = [BUILTIN_MODELS, *ctx.model_path]
    for var in ("GAZEBO_MODEL_PATH", "GZ_SIM_RESOURCE_PATH"):
        search += [Path(p) for p in os.environ.get(var, "").split(os.pathsep) if p]
    for folder in search:
        candidate = folder / name
        if (candidate / "model.sdf").is_file():
            return candidate / "model.sdf"
    raise ctx.error(f"<include> {uri}: model not found in {', '.join(str(p) for p in search)}")


def _include(el: ET.Element, world: World, ctx: _Context, parent=None) -> None:
    uri = (el.findtext("uri") or "").strip()
    path = _find_model(uri, ctx)
    inner = _Context(path, ctx.model_path)
    root = _parse(path)
    model = root.find("model")
    light = root.find("light")
    pose = _pose(el, ctx, f"include {uri}") if el.find("pose") is not None else None
    if parent is not None and pose is not None:
        pose = compose(*parent, *pose)
    if model is not None:
        static = el.findtext("static")
        _model(model, world, inner, pose if pose is not None else None, el.findtext("name"),
               None if static is None else static.strip() in ("true", "1"))
    elif light is not None:
        world.lights.append(_light(light, inner))
    else:
        raise ctx.error(f"<include> {uri}: {path} holds neither a <model> nor a <light>")


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


def _physics(el: ET.Element, ctx: _Context) -> Physics:
    physics = Physics()
    step = el.findtext("max_step_size")
    if step:
        physics.max_step_size = _numbers(step, 1, ctx, "<physics><max_step_size>")[0]
        if physics.max_step_size <= 0:
            raise ctx.error(f"<physics><max_step_size> must be positive, got {step}")
    iters = el.findtext("ode/solver/iters")
    if iters:
        physics.iterations = int(_numbers(iters, 1, ctx, "<physics><ode><solver><iters>")[0])
    return physics


def load_sdf(path: str | Path, model_path: list[Path] | None = None) -> World:
    """Load an SDF world file; raises WorldError with the file and element on bad input."""
    path = Path(path)
    root = _parse(path)
    world_el = root.find("world")
    if world_el is None:
        raise WorldError(f"{path}: no <world> element")
    ctx = _Context(path, list(model_path or []))
    world = World(world_el.get("name", path.stem), str(path))
    for el in world_el:
        if el.tag == "include":
            _include(el, world, ctx)
        elif el.tag == "model":
            _model(el, world, ctx)
        elif el.tag == "light":
            world.lights.append(_light(el, ctx))
        elif el.tag == "physics":
            world.physics = _physics(el, ctx)
        elif el.tag == "gravity":
            world.physics.gravity = _numbers(el.text, 3, ctx, "<gravity>")  # type: ignore[assignment]
        elif el.tag not in _IGNORED:
            ctx.warn(el.tag)
    gravity = world_el.findtext("physics/gravity")
    if gravity:
        world.physics.gravity = _numbers(gravity, 3, ctx, "<physics><gravity>")  # type: ignore[assignment]
    return world
