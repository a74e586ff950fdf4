"""Build the MuJoCo model (through mujoco.MjSpec) from the parsed URDF and a loaded world.

Gazebo merges links joined by fixed joints into their parent; MuJoCo's `fusestatic` does the same
(masses and inertias combined exactly), and a site per link keeps every URDF frame addressable.
"""

from __future__ import annotations

import itertools
import logging
import warnings
from pathlib import Path

import mujoco
import numpy as np

from racecar_sim.core.errors import ConfigError, DescriptionError, WorldError
from racecar_sim.core.names import CarNames
from racecar_sim.core.transforms import quat_from_axis_angle, quat_from_rpy
from racecar_sim.description.ros_packages import PackageNotFound, resolve_uri
from racecar_sim.description.urdf import Link, Robot, Shape
from racecar_sim.physics.contact import solref_solimp
from racecar_sim.physics.near_walls import add_slots
from racecar_sim.physics.presets import CONES, INTEGRATORS, SOLVERS, PhysicsPreset
from racecar_sim.physics.world_geoms import COLLISION_GROUP, GEOM_TYPES, SLEEP_POLICY, VISUAL_GROUP, add_world, mj_size
from racecar_sim.worlds.materials import gazebo_material_rgba
from racecar_sim.worlds.meshes import MeshPart, convex_pieces, load_mesh
from racecar_sim.worlds.world import Mesh, Spawn, World

ROOT_JOINT = "root"


def build_spec(robot: Robot, world: World, preset: PhysicsPreset, names: CarNames = CarNames()) -> mujoco.MjSpec:
    """The full scene for one car: options, the world's geoms and lights, and the car at the world's spawn pose."""
    spec = world_spec(world, preset)
    spec.modelname = robot.name
    add_car(spec, robot, world.spawn, preset, names)
    return spec


def world_spec(world: World, preset: PhysicsPreset, near_walls: bool = False) -> mujoco.MjSpec:
    """The world alone (options, geoms, lights): cars are added with add_car, then finish_spec before compiling.
    `near_walls`: a map's thousands of wall boxes are held out of the collision model (near_walls.py); the model
    compiled from the spec then needs fit_near_walls. WorldError for a world MuJoCo could not take or place exactly
    (beyond worlds.MAX_COORDINATE, two geoms of one name), naming the world and the model."""
    world.check_extent()  # a World built in Python has not been through load_world
    spec = mujoco.MjSpec()
    spec.modelname = world.name or "world"
    _options(spec, world, preset)
    add_world(spec, world, near_walls)
    return spec


def fit_near_walls(spec: mujoco.MjSpec, model: mujoco.MjModel) -> bool:
    """Give `spec` the near-wall slots its compiled `model` needs (one more car, one more free body needs more);
    True if the spec changed and must be compiled again."""
    return add_slots(spec, model, friction_min_rule)


def add_car(
    spec: mujoco.MjSpec,
    robot: Robot,
    spawn: Spawn,
    preset: PhysicsPreset,
    names: CarNames = CarNames(),
    rank_friction: bool = True,
) -> None:
    """One car from its URDF at `spawn`, every MuJoCo name of it from `names` (no prefix for the unnamed car).

    rank_friction=False leaves friction_min_rule to the caller: a fleet ranks every geom once, after its last car
    (ranking after each car visits every geom of the cars before it, which made building N cars cost N²)."""
    _add_robot(spec, robot, spawn, preset, names)
    if rank_friction:
        friction_min_rule(spec)


def _options(spec: mujoco.MjSpec, world: World, preset: PhysicsPreset) -> None:
    opt = spec.option
    opt.timestep = world.physics.max_step_size or preset.timestep
    opt.gravity = list(world.physics.gravity)
    opt.integrator = INTEGRATORS[preset.integrator]
    opt.solver = SOLVERS[preset.solver]
    opt.iterations = world.physics.iterations or preset.iterations
    opt.cone = CONES[preset.cone]
    # A diverging state is an error the run reports and stops on (runtime), not one MuJoCo silently resets.
    opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_AUTORESET
    # With sleeping enabled MuJoCo places static geoms once (mj_makeData, mj_resetData) instead of on every step:
    # a map of thousands of walls otherwise costs more than the car. Every moving tree is kept awake
    # (SLEEP_POLICY), so the dynamics are bit-identical to a run without it.
    opt.enableflags |= mujoco.mjtEnableBit.mjENBL_SLEEP
    spec.compiler.fusestatic = True
    spec.compiler.discardvisual = False
    spec.compiler.autolimits = True
    spec.compiler.degree = False  # URDF and SDF angles are radians
    spec.compiler.inertiafromgeom = mujoco.mjtInertiaFromGeom.mjINERTIAFROMGEOM_FALSE
    spec.visual.quality.offsamples = 0  # software GL: MSAA costs 2x per frame


def _sprung_mass(robot: Robot) -> float:
    """Mass each contact carries at rest: the car's mass shared by the links with contact surfaces."""
    total = sum(link.inertial.mass for link in robot.links.values() if link.inertial)
    contacts = sum(len(link.collisions) for link in robot.links.values() if link.surface.kp is not None)
    return total / max(contacts, 1)


def _link_rgba(link: Link, shape: Shape) -> list[float]:
    if link.surface.material:  # a <gazebo><material> overrides the URDF colour, as in Gazebo
        return list(gazebo_material_rgba(link.surface.material))
    return list(shape.rgba or (0.7, 0.7, 0.7, 1.0))


def _collision_type(shape: Shape, is_wheel: bool, preset: PhysicsPreset) -> tuple[mujoco.mjtGeom, list[float]]:
    kind, size = shape.geometry.kind, shape.geometry.size
    if is_wheel and kind == "cylinder" and preset.wheel_contact == "ellipsoid":
        return mujoco.mjtGeom.mjGEOM_ELLIPSOID, [size[0], size[0], 0.5 * size[1]]
    return GEOM_TYPES[kind], mj_size(kind, size)


def _mesh_parts(robot: Robot, link: Link, shape: Shape, what: str) -> list[MeshPart]:
    """The parts of a shape's mesh file: package://, model://, file:// or a path relative to the xacro's folder."""
    source = robot.source or f"robot {robot.name}"
    filename = shape.geometry.filename
    if not filename.strip():
        raise DescriptionError(f"{source}: link {link.name} {what} <mesh> has no filename")
    base = Path(robot.source).parent if robot.source and Path(robot.source).is_file() else None
    try:
        path = resolve_uri(filename, base, needed_by=f"{source} (link {link.name} {what} mesh)")
    except PackageNotFound:
        raise
    except ConfigError as exc:
        raise DescriptionError(str(exc)) from None
    try:
        return load_mesh(path, shape.geometry.scale)
    except WorldError as exc:
        raise DescriptionError(f"{source}: link {link.name} {what} mesh {filename}: {exc}") from None


def _add_mesh(spec: mujoco.MjSpec, mesh: Mesh, name: str) -> str:
    m = spec.add_mesh(name=name, uservert=mesh.vertices.ravel().tolist(), userface=mesh.faces.ravel().tolist())
    m.inertia = mujoco.mjtMeshInertia.mjMESH_INERTIA_SHELL  # the link's <inertial> gives the mass; any surface will do
    return name


def _add_shapes(
    spec: mujoco.MjSpec,
    body: mujoco.MjsBody,
    link: Link,
    robot: Robot,
    preset: PhysicsPreset,
    is_wheel: bool,
    names: CarNames,
) -> None:
    _add_collisions(spec, body, link, robot, preset, is_wheel, names)
    _add_visuals(spec, body, link, robot, names)


def _add_collisions(
    spec: mujoco.MjSpec,
    body: mujoco.MjsBody,
    link: Link,
    robot: Robot,
    preset: PhysicsPreset,
    is_wheel: bool,
    names: CarNames,
) -> None:
    """Collision geoms; a mesh collides as the convex hulls of its connected pieces (as SDF meshes do)."""
    for i, shape in enumerate(link.collisions):
        base_name = names.mj(f"{link.name}_collision{'' if i == 0 else i}")
        surface = link.surface
        mu = surface.mu1 if surface.mu1 is not None else 1.0  # SDF default friction
        solref, solimp = solref_solimp(surface.kp, _sprung_mass(robot), preset.contact_timeconst)
        contact = {
            "pos": list(shape.origin.xyz),
            "quat": list(quat_from_rpy(shape.origin.rpy)),
            "group": COLLISION_GROUP,
            "contype": 1,
            "conaffinity": 1,
            "condim": 3,
            "friction": [mu, 0.0, 0.0],
            "solref": solref,
            "solimp": solimp,
            "rgba": [0.9, 0.3, 0.3, 0.4],
        }
        if shape.geometry.kind == "mesh":
            pieces = []
            for part in _mesh_parts(robot, link, shape, "collision"):
                part_pieces, convex = convex_pieces(part.mesh)
                if not convex:
                    warnings.warn(
                        f"{robot.source or robot.name}: link {link.name} collision mesh "
                        f"{shape.geometry.filename} is not convex: it collides as the convex hull of each "
                        "of its connected pieces",
                        stacklevel=3,
                    )
                pieces += part_pieces
            for j, piece in enumerate(pieces):
                name = base_name if j == 0 else f"{base_name}#{j}"
                body.add_geom(
                    name=name, type=GEOM_TYPES["mesh"], meshname=_add_mesh(spec, piece, f"{name}/mesh"), **contact
                )
            continue
        geom_type, geom_size = _collision_type(shape, is_wheel, preset)
        body.add_geom(name=base_name, type=geom_type, size=geom_size, **contact)


def _add_visuals(spec: mujoco.MjSpec, body: mujoco.MjsBody, link: Link, robot: Robot, names: CarNames) -> None:
    """Visual geoms (drawn, never touched); a mesh's parts keep the file's own colours unless the URDF gives one."""
    for i, shape in enumerate(link.visuals):
        name = names.mj(f"{link.name}_visual{'' if i == 0 else i}")
        placed = {
            "pos": list(shape.origin.xyz),
            "quat": list(quat_from_rpy(shape.origin.rpy)),
            "group": VISUAL_GROUP,
            "contype": 0,
            "conaffinity": 0,
            "mass": 0.0,
        }
        if shape.geometry.kind == "mesh":
            own_colour = shape.rgba is not None or link.surface.material
            for j, part in enumerate(_mesh_parts(robot, link, shape, "visual")):
                part_name = name if j == 0 else f"{name}#{j}"
                rgba = _link_rgba(link, shape) if own_colour or part.rgba is None else list(part.rgba)
                body.add_geom(
                    name=part_name,
                    type=GEOM_TYPES["mesh"],
                    rgba=rgba,
                    meshname=_add_mesh(spec, part.mesh, f"{part_name}/mesh"),
                    **placed,
                )
            continue
        body.add_geom(
            name=name,
            type=GEOM_TYPES[shape.geometry.kind],
            size=mj_size(shape.geometry.kind, shape.geometry.size),
            rgba=_link_rgba(link, shape),
            **placed,
        )


def _add_link(
    spec: mujoco.MjSpec, parent: mujoco.MjsBody, robot: Robot, name: str, preset: PhysicsPreset, names: CarNames
) -> None:
    link = robot.links[name]
    joint = robot.joint_to(name)
    pos, quat = (
        (joint.origin.xyz, quat_from_rpy(joint.origin.rpy)) if joint else ((0.0, 0.0, 0.0), np.array([1.0, 0, 0, 0]))
    )
    body = parent.add_body(name=names.mj(name), pos=list(pos), quat=list(quat))
    if link.inertial:
        i = link.inertial
        body.explicitinertial = True
        body.mass = i.mass
        body.ipos = list(i.origin.xyz)
        body.iquat = list(quat_from_rpy(i.origin.rpy))
        body.fullinertia = [i.inertia[0], i.inertia[1], i.inertia[2], i.inertia[3], i.inertia[4], i.inertia[5]]
    body.add_site(name=names.mj(name), size=[0.005, 0.005, 0.005], group=4)  # the URDF frame, kept through fusion
    if joint and joint.moves:
        mj_joint = body.add_joint(
            name=names.mj(joint.name),
            axis=list(joint.axis),
            type=mujoco.mjtJoint.mjJNT_HINGE if joint.type != "prismatic" else mujoco.mjtJoint.mjJNT_SLIDE,
        )
        if joint.type in ("revolute", "prismatic"):
            assert joint.limit is not None, "parse_urdf gives every revolute and prismatic joint a <limit>"
            mj_joint.range = [joint.limit.lower, joint.limit.upper]
            mj_joint.limited = mujoco.mjtLimited.mjLIMITED_TRUE
            # a hard stop, as ODE's joint stop (MuJoCo's default limit is a soft 20 ms spring)
            mj_joint.solref_limit = [2 * spec.option.timestep, 1.0]
            mj_joint.solimp_limit = [0.99, 0.999, 0.001, 0.5, 2.0]
        if joint.limit and joint.limit.effort > 0:
            mj_joint.actfrcrange = [-joint.limit.effort, joint.limit.effort]
            mj_joint.actfrclimited = mujoco.mjtLimited.mjLIMITED_TRUE
    _add_shapes(spec, body, link, robot, preset, joint is not None and joint.type == "continuous", names)
    for child in (j.child for j in robot.joints.values() if j.parent == name):
        _add_link(spec, body, robot, child, preset, names)


def _add_robot(spec: mujoco.MjSpec, robot: Robot, spawn: Spawn, preset: PhysicsPreset, names: CarNames) -> None:
    root = robot.root
    _add_link(spec, spec.worldbody, robot, root, preset, names)
    base = spec.body(names.mj(root))
    base.pos = [spawn.x, spawn.y, spawn.z]
    base.quat = list(quat_from_axis_angle((0.0, 0.0, 1.0), spawn.yaw))
    base.add_freejoint(name=names.mj(ROOT_JOINT))
    base.sleep = SLEEP_POLICY
    # MuJoCo only filters parent/child contacts; the car's own parts never touch each other in Gazebo either.
    moving = [root] + [j.child for j in robot.joints.values() if j.moves]
    for a, b in itertools.combinations(moving, 2):
        spec.add_exclude(bodyname1=names.mj(a), bodyname2=names.mj(b))


def friction_min_rule(spec: mujoco.MjSpec) -> None:
    """Gazebo combines friction with min(mu_a, mu_b); MuJoCo takes the max unless priorities differ.

    Ranking geoms so that lower friction wins the priority reproduces the min rule for every pair
    (and the winner's solref/solimp are used, as Gazebo uses the softer surface's kp).
    """
    colliding = [g for g in spec.geoms if g.contype or g.conaffinity]
    levels = sorted({g.friction[0] for g in colliding}, reverse=True)
    for g in colliding:
        g.priority = levels.index(g.friction[0])


def route_mujoco_warnings() -> None:
    """Send MuJoCo's C-level warnings to the `racecar_sim.mujoco` logger (INFO) instead of raw stderr lines.

    The simulator reports what matters (a diverged state) as one error of its own; MuJoCo would otherwise
    print its own line per reset, which is how a NaN gain once produced 1,600 lines in 2 s.
    """
    if mujoco.get_mju_user_warning() is None:
        mujoco.set_mju_user_warning(_log_mujoco_warning)


def _log_mujoco_warning(message: str) -> None:
    logging.getLogger("racecar_sim.mujoco").info("MuJoCo: %s", message.strip())
