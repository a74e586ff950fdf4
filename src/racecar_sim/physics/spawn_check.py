"""Check the car's spawn pose against the compiled world, once, before the first step.

Gazebo (and MuJoCo) take any spawn pose: a car spawned below a ground plane is shot out of it, one spawned
inside a wall is held there by kilonewtons of contact force, one spawned where there is no ground falls
forever. With the car at its spawn pose (after mj_forward) this module

* measures how deep every part of the car (collision and visual geoms: the chassis is drawn but has no
  collision shape, and a car whose body is inside a wall is inside it however physics treats it) reaches
  into any world geom that collides (planes are half-spaces, as MuJoCo collides them); deeper than
  PENETRATION_TOL is an error, "below the ground" where the car must go up to get out, else "inside" the
  geom, named as MuJoCo names it (SDF model::link/collision);
* casts a ray straight down under every wheel (the children of continuous joints, the builder's rule),
  seeing only the world's colliding geoms: no hit within GROUND_SEARCH under a wheel is an error (the car
  tips off the edge and falls forever), the car landing more than DROP_WARN below its wheels a warning.

A world with no colliding geometry at all (a scene to look at, nothing to drive on) only gets a warning.

`SpawnProbe` runs the same check for many poses before a fleet is built: the world and two copies of the car,
compiled once (building N cars costs ~N² in MuJoCo's model editing, so a row that cannot fit is refused first).
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Sequence

import mujoco
import numpy as np

from racecar_sim.core.errors import WorldError
from racecar_sim.core.names import CarNames
from racecar_sim.description.urdf import Robot
from racecar_sim.physics.builder import add_car, world_spec
from racecar_sim.physics.presets import PhysicsPreset
from racecar_sim.worlds.world import MAX_COORDINATE, Spawn, World

# Deepest overlap let through: resting wheels touch the ground at ~0 m. MuJoCo pushes a penetration d out at
# ~d / 0.01 s (measured, default preset): 3 mm hops the car 2 mm, 5 mm 8 mm, 1 cm 4 cm, 2 cm 19 cm, 5 cm 1.2 m.
PENETRATION_TOL = 0.003  # m
# Largest fall taken without a warning: 10x racecar.launch's 5 cm drop and 2.6x the walker course's own 0.19 m
# (its road lies 0.142 m under the z = 0.05 spawn); from 0.5 m the car lands at 3.1 m/s.
DROP_WARN = 0.5  # m
GROUND_SEARCH = 100.0  # m below a wheel; nothing there: the car falls forever
RAY_LIFT = 0.01  # m, rays start this far above a wheel's lowest point (above any overlap let through)
SEPARATE_UP = math.cos(math.radians(45))  # a car that must move (mostly) up to get out is below the ground
ROW_CHECK_HEIGHT = 0.1  # m above the lower spawn: the sight line between two cars in a row, under any wall's top
PROBE_BEFORE = "car_before"  # SpawnProbe's second car: the one before in the row
_PARKED = Spawn(0.0, 0.0, -1e6, 0.0)  # SpawnProbe's second car when no other is near: far out of reach
_G = mujoco.mjtGeom
# as ints: numpy compares an array with one of MuJoCo's enum members through Python objects (1 ms a comparison)
_PLANE, _HFIELD, _SDF = int(_G.mjGEOM_PLANE), int(_G.mjGEOM_HFIELD), int(_G.mjGEOM_SDF)


def check_spawn(
    model: mujoco.MjModel,
    data: mujoco.MjData,
    world: World,
    robot: Robot,
    names: CarNames = CarNames(),
    spawn: Spawn | None = None,
    car_name: str | None = None,
) -> None:
    """Raise WorldError if the car, at its spawn pose in `data` (after mj_forward), overlaps the world or has no
    ground under it; warn if it will fall more than DROP_WARN. The car is the body tree of `robot.root`.
    `car_name`: how the message names the car (default: its namespace)."""
    car = _subtree_geoms(model, model.body(names.mj(robot.root)).id)
    outside = np.ones(model.ngeom, bool)
    outside[car] = False
    others = np.flatnonzero(outside)  # np.setdiff1d's answer, without its import of numpy.ma (~20 ms of a start)
    solid = others[_colliding(model, others)]
    car_name = names.namespace if car_name is None else car_name
    who = f"{car_name}'s " if car_name else ""
    where = f"{world.label}: {who}spawn pose ({_pose(spawn or world.spawn)})"
    if len(solid) == 0:
        warnings.warn(f"{world.label}: the world has no collision geometry: nothing holds the car up", stacklevel=3)
        return
    _check_overlap(model, data, car, solid, where)
    probes = _probes(model, data, car, robot, names)
    if not probes:
        return
    drops = []
    for name, point in probes:
        drop = _drop_below(model, data, point, solid)
        if drop is None:
            raise WorldError(
                f"{where} has no ground under it: nothing within {GROUND_SEARCH:g} m below the "
                f"{name} (the car would fall forever)"
            )
        drops.append(drop)
    fall = min(drops)  # the car falls until its first wheel lands
    if fall > DROP_WARN:
        warnings.warn(f"{where} is {fall:.3g} m above the ground: the car will fall {fall:.3g} m", stacklevel=3)


def _pose(s: Spawn) -> str:
    return ", ".join(f"{v:g}" for v in (s.x, s.y, s.z, s.yaw))


def _colliding(model: mujoco.MjModel, geoms: np.ndarray | int) -> np.ndarray:
    """Whether each geom takes part in contacts."""
    return (model.geom_contype[geoms] != 0) | (model.geom_conaffinity[geoms] != 0)


def _name(model: mujoco.MjModel, geom: int) -> str:
    return model.geom(geom).name or model.body(model.geom_bodyid[geom]).name or f"geom {geom}"


def _subtree_geoms(model: mujoco.MjModel, root: int) -> np.ndarray:
    inside = np.zeros(model.nbody, bool)
    inside[root] = True
    for body in range(root + 1, model.nbody):  # MuJoCo numbers parents before their children
        inside[body] = inside[model.body_parentid[body]]
    return np.flatnonzero(inside[model.geom_bodyid])


def _check_overlap(model: mujoco.MjModel, data: mujoco.MjData, car: np.ndarray, solid: np.ndarray, where: str) -> None:
    """WorldError naming the deepest overlap of a car geom with a colliding world geom, if beyond PENETRATION_TOL."""
    gap = np.linalg.norm(data.geom_xpos[car][:, None] - data.geom_xpos[solid][None], axis=2)
    reach = model.geom_rbound[car][:, None] + model.geom_rbound[solid][None] + PENETRATION_TOL
    kinds = model.geom_type[solid]
    near = (gap <= reach) | (kinds == _PLANE)[None]  # a plane's rbound is 0
    near &= ((kinds != _HFIELD) & (kinds != _SDF))[None]  # no distance function (the loader makes none)
    fromto = np.zeros(6)
    found: list[tuple[bool, float, int, int, np.ndarray]] = []
    for i, j in zip(*np.nonzero(near)):
        dist = mujoco.mj_geomDistance(model, data, int(car[i]), int(solid[j]), 0.0, fromto)
        if dist < -PENETRATION_TOL:  # fromto: the car's deepest point, then the obstacle's surface point
            found.append((not _colliding(model, car[i]), dist, int(car[i]), int(solid[j]), fromto[3:] - fromto[:3]))
    if not found:
        return
    _, dist, part, obstacle, out = min(found, key=lambda f: f[:2])  # the deepest, a collision geom if one overlaps
    length = float(np.linalg.norm(out))
    if length > 0 and out[2] >= SEPARATE_UP * length:
        raise WorldError(
            f"{where} is below the ground: the car's {_name(model, part)} is {-dist:.3g} m under the "
            f"surface of {_name(model, obstacle)}"
        )
    raise WorldError(
        f"{where} is inside an obstacle: the car's {_name(model, part)} is {-dist:.3g} m into {_name(model, obstacle)}"
    )


def _probes(
    model: mujoco.MjModel, data: mujoco.MjData, car: np.ndarray, robot: Robot, names: CarNames
) -> list[tuple[str, np.ndarray]]:
    """(name, lowest point) of each wheel's collision geoms; of the car's lowest collision geom if it has no wheels."""
    colliding = car[_colliding(model, car)]
    wheels = {model.body(names.mj(j.child)).id for j in robot.joints.values() if j.type == "continuous"}
    probes = [
        (model.body(model.geom_bodyid[g]).name, lowest_point(model, data, g))
        for g in colliding
        if model.geom_bodyid[g] in wheels
    ]
    if not probes and len(colliding):
        lowest = [lowest_point(model, data, g) for g in colliding]
        k = int(np.argmin([p[2] for p in lowest]))
        probes = [(_name(model, int(colliding[k])), lowest[k])]
    return probes


def lowest_point(model: mujoco.MjModel, data: mujoco.MjData, geom: int) -> np.ndarray:
    """The world point of a geom that lies lowest (its support point along -z)."""
    pos, rot = data.geom_xpos[geom], data.geom_xmat[geom].reshape(3, 3)
    size, kind = model.geom_size[geom], int(model.geom_type[geom])
    down = rot.T @ np.array([0.0, 0.0, -1.0])  # in the geom's frame
    if kind == _G.mjGEOM_SPHERE:
        local = size[0] * down
    elif kind == _G.mjGEOM_ELLIPSOID:
        local = size**2 * down / np.linalg.norm(size * down)
    elif kind == _G.mjGEOM_BOX:
        local = size * np.sign(down)
    elif kind in (_G.mjGEOM_CYLINDER, _G.mjGEOM_CAPSULE):
        end = np.array([0.0, 0.0, size[1] * np.sign(down[2])])
        if kind == _G.mjGEOM_CAPSULE:
            local = end + size[0] * down
        else:
            radial = np.array([down[0], down[1], 0.0])
            n = np.linalg.norm(radial)
            local = end + (size[0] * radial / n if n > 1e-12 else 0.0)
    elif kind == _G.mjGEOM_MESH:
        mesh = model.geom_dataid[geom]
        vertices = model.mesh_vert[model.mesh_vertadr[mesh] : model.mesh_vertadr[mesh] + model.mesh_vertnum[mesh]]
        local = vertices[int(np.argmax(vertices @ down))].astype(float)
    else:
        local = model.geom_rbound[geom] * down
    return pos + rot @ local


def _drop_below(model: mujoco.MjModel, data: mujoco.MjData, point: np.ndarray, solid: np.ndarray) -> float | None:
    """How far below `point` the first colliding world geom lies straight down (None: nothing within GROUND_SEARCH).

    mj_ray excludes one body only; the car has several, so for this cast every geom but `solid` goes to another
    group (nothing reads geom_group during a ray cast) and is put back at once.
    """
    groups = model.geom_group.copy()
    mask = np.zeros(mujoco.mjNGROUP, np.uint8)
    mask[0] = 1
    hit = np.array([-1], np.int32)
    start = np.array([point[0], point[1], point[2] + RAY_LIFT])
    try:
        model.geom_group[:] = 1
        model.geom_group[solid] = 0
        dist = mujoco.mj_ray(model, data, start, np.array([0.0, 0.0, -1.0]), mask, 1, -1, hit)
    finally:
        model.geom_group[:] = groups
    if hit[0] < 0 or dist > GROUND_SEARCH + RAY_LIFT:
        return None
    return float(dist - RAY_LIFT)


class CarOverlap(WorldError):
    """A spawn pose of a row puts the car inside another car of the row."""


class SpawnProbe:
    """The world and two copies of one car, compiled once, to check a row of spawn poses before the fleet is built.

    check() puts the first copy at a pose and the second at each earlier car of the row within reach of it, and runs
    check_spawn: the same test the Simulator runs once every car is built, with every wall box of a map a geom (no
    near-wall slots to place). wall_between() finds a wall across a straight row. Milliseconds a pose.
    MuJoCo's ValueError if the world itself does not compile (the Simulator's build then reports it).
    """

    def __init__(self, world: World, robot: Robot, preset: PhysicsPreset) -> None:
        self.world, self.robot = world, robot
        spec = world_spec(world, preset, near_walls=False)
        self._names = (CarNames(), CarNames(PROBE_BEFORE))
        for names in self._names:
            add_car(spec, robot, Spawn(), preset, names, rank_friction=False)  # no contacts: friction plays no part
        self.model = spec.compile()
        self.data = mujoco.MjData(self.model)
        roots = [self.model.body(names.mj(robot.root)).id for names in self._names]
        self._qpos = [int(self.model.jnt_qposadr[self.model.body_jntadr[root]]) for root in roots]
        self._place(_PARKED)
        mujoco.mj_forward(self.model, self.data)
        car = _subtree_geoms(self.model, roots[0])
        # how far from base_link a part of the car reaches: two cars farther apart than twice this cannot touch
        self.reach = float(
            np.max(
                np.linalg.norm(self.data.geom_xpos[car] - self.data.xpos[roots[0]], axis=1)
                + self.model.geom_rbound[car]
            )
        )

    def _place(self, spawn: Spawn, other: Spawn = _PARKED) -> None:
        for adr, pose in zip(self._qpos, (spawn, other)):
            self.data.qpos[adr : adr + 3] = (pose.x, pose.y, pose.z)
            self.data.qpos[adr + 3 : adr + 7] = (math.cos(pose.yaw / 2), 0.0, 0.0, math.sin(pose.yaw / 2))

    def check(self, spawn: Spawn, car_name: str = "", others: Sequence[tuple[str, Spawn]] = ()) -> None:
        """WorldError if a car at `spawn` would be beyond MAX_COORDINATE, in the world's geometry or over nothing;
        CarOverlap if it would be inside one of the `others` (name, pose), the cars placed before it. Warnings are
        left to the Simulator's own check."""
        who = f"{car_name}'s " if car_name else ""
        if not (math.hypot(spawn.x, spawn.y, spawn.z) <= MAX_COORDINATE):
            raise WorldError(
                f"{self.world.label}: {who}spawn pose ({_pose(spawn)}) is beyond {MAX_COORDINATE:g} m "
                "from the origin, the largest world coordinate"
            )
        near = 2 * self.reach + PENETRATION_TOL
        beside = [
            (name, pose)
            for name, pose in others
            if math.hypot(pose.x - spawn.x, pose.y - spawn.y, pose.z - spawn.z) < near
        ]
        for other_name, other in beside or [("", _PARKED)]:
            self._place(spawn, other)
            mujoco.mj_forward(self.model, self.data)
            try:
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    check_spawn(self.model, self.data, self.world, self.robot, self._names[0], spawn, car_name)
            except WorldError as exc:
                message = str(exc)
                if f"{PROBE_BEFORE}/" not in message:
                    raise
                # the second copy's parts are named car_before/...: name them as the car they stand for
                raise CarOverlap(message.replace(f"{PROBE_BEFORE}/", f"{other_name}/" if other_name else "")) from None

    def wall_between(self, a: Spawn, b: Spawn) -> str | None:
        """The first colliding geom fixed to the world on the sight line from base_link at `a` to base_link at `b`,
        ROW_CHECK_HEIGHT above the lower one (cars and loose objects do not count), or None."""
        model, data = self.model, self.data
        start = np.array([a.x, a.y, min(a.z, b.z) + ROW_CHECK_HEIGHT])
        vec = np.array([b.x - a.x, b.y - a.y, 0.0])
        geomid = np.zeros(1, dtype=np.int32)
        travelled = 0.0
        while travelled < 1.0:
            hit = mujoco.mj_ray(model, data, start + travelled * vec, vec, None, 1, -1, geomid)
            if hit < 0 or travelled + hit > 1.0:
                return None
            geom = int(geomid[0])
            if model.body_weldid[model.geom_bodyid[geom]] == 0 and _colliding(model, geom):
                return _name(model, geom)
            travelled += hit + 1e-6  # past a car's or a loose object's geom, and on
        return None
