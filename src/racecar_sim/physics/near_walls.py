"""Near walls: a map's thousands of wall boxes kept out of MuJoCo's collision, a few stand-ins placed where the cars
are.

MuJoCo's broad phase visits every geom of a model on every step, and each car body walks the world's tree of
walls, so a map of 2,000 boxes costs half again the physics of an empty world - though a car can only touch the
few boxes within a metre of it. A static body whose collision boxes are that many (`MIN_BOXES`) therefore goes
into the model as data: its boxes are a custom numeric field (`LIBRARY` + the body's name: centre, quaternion and
half sizes per box), the walls the camera draws stay as they were, and the model gets `slots`: collision boxes on
the world body, in NEAR_WALL_GROUP (contacts see them, ray casts and the camera do not). `NearWalls`
keeps in the slots every box within reach of a car or free body, looked up by the 1 m cell it is in, padded by
SLACK, and looks again before any mover can have left that padding (refresh() says when), so contacts are
exactly those the full set of walls would give. The lidar reads the same boxes from the model (`WallBoxes.of`).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import mujoco
import numpy as np

from racecar_sim.core.transforms import quat_to_matrix

NEAR_WALL_GROUP = 4  # collision only: the lidar sees the walls themselves (WallBoxes), the camera their visuals
MIN_BOXES = 200  # a static body with this many collision boxes is held out of the collision model
LIBRARY = "near_walls:"  # numeric field per held-out body: friction, then (x, y, z, qw, qx, qy, qz, hx, hy, hz) per box
SLOT = "near_wall:"  # the slot geoms, numbered
CELL = 1.0  # m, side of the cells the boxes near a mover are looked up by
SLACK = 0.5  # m, how far beyond its cell a mover may go and still have every box it can touch held
LONGEST_WAIT = 0.25  # s, between two looks at where the movers are
SPEED_FLOOR = 2.0  # m/s, added to the speed bound: what a mover at rest can reach before the next look (~ 10 m/s^2)
REACH_MARGIN = 0.1  # m, over a mover's measured reach: steering and suspension move parts about its root
PARK_DEPTH = 1.0e4  # m: an unused slot waits this far under the world, where nothing is
MOST_CELLS = 1 << 22  # cells counted at most when sizing the slots (32 MB), however far a map's boxes spread
_PARK_HALF = np.array([1e-3, 1e-3, 1e-3])
_ROW = 10


@dataclass
class WallBoxes:
    """The held-out wall boxes of a model: centres (n, 3), quaternions (n, 4, w first), half sizes (n, 3)."""

    pos: np.ndarray
    quat: np.ndarray
    half: np.ndarray
    friction: float

    @classmethod
    def of(cls, model: mujoco.MjModel) -> WallBoxes | None:
        """Every held-out box of `model` (None if it has none)."""
        rows, friction = [], 0.0
        for i in range(model.nnumeric):
            if mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_NUMERIC, i).startswith(LIBRARY):
                adr, size = model.numeric_adr[i], model.numeric_size[i]
                data = model.numeric_data[adr : adr + size]
                friction = float(data[0])
                rows.append(data[1:].reshape(-1, _ROW))
        if not rows:
            return None
        table = np.concatenate(rows)
        return cls(table[:, :3].copy(), table[:, 3:7].copy(), table[:, 7:].copy(), friction)

    def __len__(self) -> int:
        return len(self.pos)

    def rotations(self) -> np.ndarray:
        """(n, 3, 3) world-from-box rotations."""
        return np.array([quat_to_matrix(q) for q in self.quat]).reshape(-1, 3, 3)

    def corners_xy(self) -> tuple[np.ndarray, np.ndarray]:
        """Lower and upper (x, y) corners (n, 2) of each box's axis-aligned bound."""
        extent = np.abs(self.rotations()) @ self.half[:, :, None]
        return self.pos[:, :2] - extent[:, :2, 0], self.pos[:, :2] + extent[:, :2, 0]

    def ray_model(self, group: int) -> tuple[mujoco.MjModel, mujoco.MjData]:
        """A model of the boxes alone on the world body, in `group`, posed: for MuJoCo's 3-D ray casts."""
        spec = mujoco.MjSpec()
        for pos, quat, half in zip(self.pos.tolist(), self.quat.tolist(), self.half.tolist()):
            spec.worldbody.add_geom(
                type=mujoco.mjtGeom.mjGEOM_BOX, pos=pos, quat=quat, size=half, group=group, contype=0, conaffinity=0
            )
        model = spec.compile()
        data = mujoco.MjData(model)
        mujoco.mj_kinematics(model, data)
        return model, data


def hold_out(
    spec: mujoco.MjSpec, name: str, friction: float, boxes: list[tuple[np.ndarray, np.ndarray, tuple[float, ...]]]
) -> None:
    """Put the collision boxes (pos, quat, full size) of the static body `name` into `spec` as data."""
    rows = [[*pos, *quat, *(0.5 * np.asarray(size[:3]))] for pos, quat, size in boxes]
    spec.add_numeric(name=LIBRARY + name, data=[friction, *np.ravel(rows).tolist()])


def can_hold(spec: mujoco.MjSpec, friction: float) -> bool:
    """Whether boxes of `friction` may join the boxes `spec` holds out already: the slots have one friction."""
    return all(numeric.data[0] == friction for numeric in spec.numerics if numeric.name.startswith(LIBRARY))


def drop(spec: mujoco.MjSpec, name: str) -> None:
    """Remove the held-out boxes of the static body `name` (its model was deleted), if any."""
    for numeric in spec.numerics:
        if numeric.name == LIBRARY + name:
            spec.delete(numeric)


def slots_needed(model: mujoco.MjModel) -> int:
    """Slots the model needs: per mover, the most boxes any cell can ask for (0 without held-out boxes)."""
    boxes = WallBoxes.of(model)
    if boxes is None:
        return 0
    lower, upper = boxes.corners_xy()
    return sum(_most_per_cell(lower, upper, reach + SLACK) for reach in _movers(model)[1])


def add_slots(spec: mujoco.MjSpec, model: mujoco.MjModel, friction_rule: Callable[[mujoco.MjSpec], None]) -> bool:
    """Give `spec` the slots `model` (compiled from it) needs; True if it changed and must be compiled again.
    `friction_rule(spec)` ranks the new geoms' friction among the others' (builder.friction_min_rule)."""
    boxes = WallBoxes.of(model)
    have = sum(1 for geom in spec.geoms if geom.name.startswith(SLOT))
    need = slots_needed(model)
    if boxes is None or need <= have:
        return False
    for k in range(have, need):
        spec.worldbody.add_geom(
            name=f"{SLOT}{k}",
            type=mujoco.mjtGeom.mjGEOM_BOX,
            size=_PARK_HALF.tolist(),
            pos=_parking(k).tolist(),
            group=NEAR_WALL_GROUP,
            contype=1,
            conaffinity=1,
            condim=3,
            friction=[boxes.friction, 0.0, 0.0],
            rgba=[0.5, 0.5, 0.5, 1.0],
        )
    friction_rule(spec)
    return True


def _parking(slots: np.ndarray | int) -> np.ndarray:
    """Where unused slots wait: far under the world, each in a place of its own, in slot order (the world's
    bounding-volume tree is built over these places, so that the slots in use, the first ones, share subtrees)."""
    slots = np.asarray(slots, float)
    return np.stack([10.0 * slots, np.zeros_like(slots), np.full_like(slots, -PARK_DEPTH)], axis=-1)


def _movers(model: mujoco.MjModel) -> tuple[np.ndarray, list[float]]:
    """Root bodies of the model's free trees, and how far from its root each tree's collision geoms reach (posed
    at qpos0: the same figure wherever the tree is, so that slots_needed and NearWalls agree)."""
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    roots = np.array(
        [
            b
            for b in range(1, model.nbody)
            if model.body_parentid[b] == 0
            and model.body_dofnum[b] > 0
            and model.jnt_type[model.body_jntadr[b]] == mujoco.mjtJoint.mjJNT_FREE
        ],
        int,
    )
    colliding = (model.geom_contype != 0) | (model.geom_conaffinity != 0)
    reach = []
    for root in roots.tolist():
        geoms = np.flatnonzero(colliding & (model.body_rootid[model.geom_bodyid] == root))
        far = np.linalg.norm(data.geom_xpos[geoms] - data.xpos[root], axis=1) + model.geom_rbound[geoms]
        reach.append(float(far.max(initial=0.0)) + REACH_MARGIN)
    return roots, reach


def _cell_range(lower: np.ndarray, upper: np.ndarray, pad: float) -> tuple[np.ndarray, np.ndarray]:
    """First and last cells (n, 2) whose square, padded by `pad`, meets each bound (NearWalls._near's test, the pad
    a micrometre wider against rounding: a count from these ranges is never short)."""
    pad += 1e-6
    return np.ceil((lower - pad) / CELL).astype(int) - 1, np.floor((upper + pad) / CELL).astype(int)


def _most_per_cell(lower: np.ndarray, upper: np.ndarray, pad: float) -> int:
    """The most boxes whose bound, padded by `pad`, meets any one cell."""
    first, last = _cell_range(lower, upper, pad)
    origin = first.min(axis=0)
    first, last = first - origin, last - origin + 1
    shape = last.max(axis=0) + 1
    if int(shape[0]) * int(shape[1]) > MOST_CELLS:  # a map kilometres across: count between the boxes' edges only
        edges = [np.unique(np.concatenate([first[:, k], last[:, k]])) for k in range(2)]
        if len(edges[0]) * len(edges[1]) > MOST_CELLS:
            return len(lower)  # every box: never too few
        first = np.stack([np.searchsorted(edges[k], first[:, k]) for k in range(2)], axis=1)
        last = np.stack([np.searchsorted(edges[k], last[:, k]) for k in range(2)], axis=1)
        shape = np.array([len(edges[0]), len(edges[1])]) + 1
    counts = np.zeros(tuple(shape), int)
    for (x0, y0), (x1, y1) in zip(first.tolist(), last.tolist()):  # a 2-D difference array: +1 over each box's cells
        counts[x0, y0] += 1
        counts[x1, y0] -= 1
        counts[x0, y1] -= 1
        counts[x1, y1] += 1
    return int(counts.cumsum(axis=0).cumsum(axis=1).max())


class NearWalls:
    """Keeps every held-out wall box a car or free body can touch in the model's slots.

    refresh() looks at where each mover is and, when one has entered another cell, puts the boxes within its
    reach + SLACK of that cell into slots (a box stays in its slot while it is needed), parking the rest, and
    says how long that surely holds. The Simulator calls it then, after a reset and after a teleport; the order
    of the slots is a function of the movers' cells alone, so a run is deterministic.
    """

    def __init__(self, model: mujoco.MjModel, data: mujoco.MjData) -> None:
        self.rebind(model, data)

    @classmethod
    def of(cls, model: mujoco.MjModel, data: mujoco.MjData) -> NearWalls | None:
        """NearWalls for a model with held-out boxes, else None."""
        return cls(model, data) if WallBoxes.of(model) is not None else None

    def rebind(self, model: mujoco.MjModel, data: mujoco.MjData) -> None:
        """Work on a recompiled model (a model was spawned or deleted): boxes, slots and movers are read again."""
        self.model, self.data = model, data
        boxes = WallBoxes.of(model)
        self.boxes = boxes if boxes is not None else WallBoxes(np.zeros((0, 3)), np.zeros((0, 4)), np.zeros((0, 3)), 0)
        self._lower, self._upper = self.boxes.corners_xy()
        rotations = self.boxes.rotations()
        self._rotations = rotations.reshape(-1, 9)
        self._extent = (np.abs(rotations) @ self.boxes.half[:, :, None])[:, :, 0]  # half sizes of the world bound
        slots = [g for g in range(model.ngeom) if _name(model, g).startswith(SLOT)]
        self.geoms = np.array(sorted(slots, key=lambda g: int(_name(model, g)[len(SLOT) :])), int)
        self._tree = _WorldTree(model)
        self._leaves = np.array([self._tree.node_of_geom[g] for g in self.geoms.tolist()], int)
        self.roots, self.reach = _movers(model)
        self._dofs = model.body_dofadr[self.roots].tolist()  # a free joint's linear, then angular velocity
        self.held = np.full(len(self.geoms), -1)  # box in each slot, -1 parked
        k = len(self.geoms)
        self._parked = (
            _parking(np.arange(k)),
            np.tile([1.0, 0.0, 0.0, 0.0], (k, 1)),
            np.tile(_PARK_HALF, (k, 1)),
            np.tile(np.eye(3).ravel(), (k, 1)),
        )
        self._cells: tuple[tuple[int, int], ...] | None = None
        self._lists: dict[tuple[int, int, int], np.ndarray] = {}
        self._park(np.arange(len(self.geoms)))
        self.refresh(force=True)

    def refresh(self, force: bool = False) -> float:
        """Fill the slots for the movers' current cells (nothing to do while none has changed cell); the seconds
        until the next look is due."""
        xy = [(x, y) for x, y, _ in self.data.xpos[self.roots].tolist()]
        cells = tuple((math.floor(x / CELL), math.floor(y / CELL)) for x, y in xy)
        if cells != self._cells or force:
            self._fill(cells)
        return self._safe_for(xy)

    def _safe_for(self, xy: list[tuple[float, float]]) -> float:
        """How long every mover surely stays within SLACK of its cell: the distance to the nearest cell edge plus
        SLACK, over a bound on the speed of any mover's parts (the fastest one's, doubled as it may knock another
        that fast, plus SPEED_FLOOR for what a push or a throttle adds meanwhile); at most LONGEST_WAIT."""
        room, speed, qvel = math.inf, 0.0, self.data.qvel
        for (x, y), adr, reach in zip(xy, self._dofs, self.reach):
            u, v = x / CELL - math.floor(x / CELL), y / CELL - math.floor(y / CELL)
            room = min(room, CELL * min(u, 1.0 - u, v, 1.0 - v))
            vx, vy, vz, wx, wy, wz = qvel[adr : adr + 6].tolist()
            speed = max(speed, math.sqrt(vx * vx + vy * vy + vz * vz) + math.sqrt(wx * wx + wy * wy + wz * wz) * reach)
        return min(LONGEST_WAIT, (SLACK + room) / (2.0 * speed + SPEED_FLOOR))

    def _fill(self, cells: tuple[tuple[int, int], ...]) -> None:
        self._cells = cells
        wanted = np.unique(np.concatenate([np.zeros(0, int)] + [self._near(i, c) for i, c in enumerate(cells)]))
        if len(wanted) > len(self.geoms):
            raise RuntimeError(f"near walls: {len(wanted)} boxes within reach but {len(self.geoms)} slots")
        keep = np.isin(self.held, wanted)
        self._park(np.flatnonzero(~keep & (self.held >= 0)))
        new = np.setdiff1d(wanted, self.held[keep])
        self._put(np.flatnonzero(self.held < 0)[: len(new)], new)
        self._tree.refit(self.model)

    def _near(self, mover: int, cell: tuple[int, int]) -> np.ndarray:
        """Boxes whose bound meets the cell padded by the mover's reach + SLACK (cached per mover and cell)."""
        key = (mover, *cell)
        if key not in self._lists:
            pad = self.reach[mover] + SLACK
            low = np.array(cell) * CELL - pad
            high = (np.array(cell) + 1) * CELL + pad
            meets = np.all((self._upper >= low) & (self._lower <= high), axis=1)
            self._lists[key] = np.flatnonzero(meets)
        return self._lists[key]

    def _put(self, slots: np.ndarray, boxes: np.ndarray) -> None:
        """Put `boxes` into `slots`: the geoms' pose, size and bounds in the model and, as the world's geoms are
        posed only at a reset, their posed frames in the data; their leaves of the world's tree (refit after)."""
        self._write(
            slots,
            boxes,
            self.boxes.pos[boxes],
            self.boxes.quat[boxes],
            self.boxes.half[boxes],
            self._rotations[boxes],
            self._extent[boxes],
        )

    def _park(self, slots: np.ndarray) -> None:
        """Send `slots` to their parking places, out of the collision (contype and conaffinity 0)."""
        pos, quat, half, rotation = self._parked
        self._write(slots, np.full(len(slots), -1), pos[slots], quat[slots], half[slots], rotation[slots], half[slots])

    def _write(
        self,
        slots: np.ndarray,
        boxes: np.ndarray,
        pos: np.ndarray,
        quat: np.ndarray,
        half: np.ndarray,
        rotation: np.ndarray,
        extent: np.ndarray,
    ) -> None:
        m, d, geoms = self.model, self.data, self.geoms[slots]
        self.held[slots] = boxes
        m.geom_contype[geoms] = m.geom_conaffinity[geoms] = (boxes >= 0).astype(m.geom_contype.dtype)
        m.geom_pos[geoms], m.geom_quat[geoms] = pos, quat
        m.geom_size[geoms] = half
        m.geom_aabb[geoms, 3:] = half
        m.geom_rbound[geoms] = np.linalg.norm(half, axis=1)
        d.geom_xpos[geoms], d.geom_xmat[geoms] = pos, rotation
        m.bvh_aabb[self._leaves[slots], :3], m.bvh_aabb[self._leaves[slots], 3:] = pos, extent


class _WorldTree:
    """The world body's bounding-volume tree (boxes in the world frame, centre and half sizes), refit bottom-up
    after geoms of the world moved: its shape is the compiled one, its boxes again enclose their children."""

    def __init__(self, model: mujoco.MjModel) -> None:
        first, count = int(model.body_bvhadr[0]), int(model.body_bvhnum[0])
        nodes = np.arange(first, first + count)
        child = model.bvh_child[nodes]
        leaves = nodes[child[:, 0] < 0]
        self.node_of_geom = dict(zip(model.bvh_nodeid[leaves].tolist(), leaves.tolist()))
        # children come after their parent (MuJoCo builds the tree depth first): refit runs backwards
        inner = nodes[child[:, 0] >= 0][::-1]
        pairs = np.where(child < 0, child[:, :1], child)  # a node with one child unites it with itself
        self._inner, self._children = inner, np.ascontiguousarray(first + pairs[inner - first])
        if not (self._children > inner[:, None]).all():
            raise RuntimeError("near walls: MuJoCo's world tree lists a child before its parent; cannot refit it")

    def refit(self, model: mujoco.MjModel) -> None:
        """Recompute every inner node's box as the union of its children's (the leaves are written already)."""
        from racecar_sim.physics.tree_refit import refit  # compiled (numba): a map's only per-refit cost

        refit(model.bvh_aabb, self._inner, self._children)


def _name(model: mujoco.MjModel, geom: int) -> str:
    return mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_GEOM, geom) or ""
