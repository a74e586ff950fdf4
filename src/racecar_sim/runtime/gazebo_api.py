"""gazebo_ros_api_plugin: Gazebo's ROS API (/gazebo/...) on the Simulator, as the original nodes and tools use it.

Topics (gazebo_msgs, recorded like every topic):
  /gazebo/model_states   every model by its Gazebo name - world models by their SDF model name (`ground_plane`,
                         `cone_1`, `MIT_Tunnel`), cars by their model name (`racecar` for the unnamed car, as
                         `spawn_model -model racecar` named it; `car2` in a fleet) - with pose and twist in the world
  /gazebo/link_states    every link, named `model::link` (`racecar::base_link`, `racecar::left_front_wheel`,
                         `car2::base_link`, `cone_1::link`, `MIT_Tunnel::Wall_10`)
  /gazebo/set_model_state  (subscribed) a gazebo_msgs/ModelState: the same as the set_model_state service

Gazebo publishes the two state topics at every world update (1 kHz); here they go out at STATES_RATE of sim time
(with /clock), and only while someone listens, as the sensors do: Python runs at event rates, never per physics
step. A model's pose is its canonical (first) link's pose times the link-to-model offset it was loaded with, and
its twist that link's twist (Gazebo's Model::WorldPose / WorldLinearVel); a car's is its base_link's, so
/gazebo/model_states and /vesc/odom carry the same pose at equal stamps (the odometry node reads the same MjData
through the same CarState calls the original's `racecar::base_link` entry comes from). Twists are the world-frame
velocities of the link frame origins. Static models never move and have zero twist.

Services (`sim.bus.call("/gazebo/<name>", request)`, requests and responses in racecar_sim.msgs.gazebo_msgs):
  get_model_state, set_model_state, spawn_urdf_model, spawn_sdf_model, delete_model, get_world_properties
  (gazebo_msgs), and pause_physics, unpause_physics, reset_simulation, reset_world (std_srvs/Empty).
Spawning and deleting change the MuJoCo model: the scene's MjSpec is edited and recompiled (the state of
everything that stays is kept) and every node is rebound to the new model, none rebuilt.
"""

from __future__ import annotations

import logging
import tempfile
import warnings
import xml.etree.ElementTree as ET
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Protocol, cast

import mujoco
import numpy as np

from racecar_sim.bus import BusPort, ListenerAnswer, type_name
from racecar_sim.core.errors import RacecarSimError, WorldError
from racecar_sim.core.names import CarNames
from racecar_sim.core.throttle import ThrottledWarning
from racecar_sim.core.transforms import compose, quat_mul, quat_rotate, quat_to_matrix, yaw_of
from racecar_sim.msgs import Header, Point, Pose, Quaternion, Twist, Vector3, serialize
from racecar_sim.msgs.cdr_layout import CdrLayout, FilledLayout
from racecar_sim.msgs.gazebo_msgs import (
    DeleteModelRequest,
    DeleteModelResponse,
    GetModelStateRequest,
    GetModelStateResponse,
    GetWorldPropertiesRequest,
    GetWorldPropertiesResponse,
    LinkStates,
    ModelState,
    ModelStates,
    SetModelStateRequest,
    SetModelStateResponse,
    SpawnModelRequest,
    SpawnModelResponse,
)
from racecar_sim.msgs.link_arrays import LinkArrays
from racecar_sim.msgs.std_srvs import EmptyRequest, EmptyResponse
from racecar_sim.nodes import NodeBase, Timers
from racecar_sim.runtime.car import Car
from racecar_sim.worlds import Spawn, World
from racecar_sim.worlds.sdf import load_sdf
from racecar_sim.worlds.sdf_parts import SdfContext, pose, pose_or_identity, resolve_uri
from racecar_sim.worlds.world import WorldBody

log = logging.getLogger("racecar_sim")

STATES_RATE = 100.0  # Hz of sim time for /gazebo/link_states and /gazebo/model_states (Gazebo: every 1 ms step)
LINK_STATES = "/gazebo/link_states"
MODEL_STATES = "/gazebo/model_states"
SET_MODEL_STATE = "/gazebo/set_model_state"  # the topic; the service has the same name
NAMESPACE = "/gazebo"
WORLD_FRAMES = ("", "world", "map", "/map")  # what gazebo_ros takes for the inertial frame
_IDENTITY = (np.zeros(3), np.array([1.0, 0.0, 0.0, 0.0]))
_ZERO_TWIST = (np.zeros(3), np.zeros(3))
_FREE_POSE_ROS = np.array([0, 1, 2, 4, 5, 6, 3])  # a free joint's qpos (x y z, qw qx qy qz) as a ROS pose's order
_XBODY = int(mujoco.mjtObj.mjOBJ_XBODY)  # as a plain int: MuJoCo's functions take it, and convert it faster

PoseArrays = tuple[np.ndarray, np.ndarray]  # position (3,), quaternion (w, x, y, z)


@dataclass
class _Link:
    name: str  # Gazebo's scoped name, model::link
    body: int  # MuJoCo body id, -1 for a static link (its geoms are welded to the world body)
    pose: PoseArrays  # a static link's world pose
    qpos: int = -1  # qpos address of the body's free joint, -1 if it has none
    dof: int = -1


@dataclass
class _Model:
    name: str
    links: list[_Link]
    car: Car | None = None
    offset: PoseArrays = _IDENTITY  # canonical (first) link frame -> model frame
    frame: PoseArrays = _IDENTITY  # the model's pose as loaded (a static model's for good)
    bodies: list[WorldBody] = field(default_factory=list)  # a world object's links, as loaded

    @property
    def movable(self) -> bool:
        return any(link.qpos >= 0 for link in self.links)


class GazeboHost(Protocol):
    """What the Gazebo API needs of the simulation: reads of its state, and the few calls that change the scene."""

    world: World
    cars: list[Car]
    paused: bool
    seed: int

    @property
    def bus(self) -> BusPort: ...

    @property
    def scheduler(self) -> Timers: ...

    @property
    def model(self) -> mujoco.MjModel: ...

    @property
    def data(self) -> mujoco.MjData: ...

    @property
    def time_ns(self) -> int: ...

    @property
    def time(self) -> float: ...

    def poses_changed(self) -> None: ...

    def defer(self, action: Callable[[], None]) -> None: ...

    def reset(self) -> None: ...

    def spawn_car(self, car: Car, quat: Sequence[float] | np.ndarray | None = None) -> None: ...

    def delete_car(self, car: Car) -> None: ...

    def add_world_bodies(self, bodies: list[WorldBody], prefix: str) -> None: ...

    def remove_world_bodies(self, bodies: list[WorldBody]) -> None: ...


class GazeboApi(NodeBase):
    """The gazebo node: state topics at STATES_RATE, the /gazebo services. Created by the Simulator (`sim.gazebo`),
    a node of the world: it changes the scene only through the host's spawn and delete calls."""

    def __init__(self, sim: GazeboHost) -> None:
        self.sim, self.bus = sim, sim.bus
        # whether only a recorder takes both state topics (their bytes), asked again when the bus's listeners change
        self._bytes_alone = ListenerAnswer(lambda: self.bus.cdr_only(LINK_STATES) and self.bus.cdr_only(MODEL_STATES))
        self._frames = _world_file_frames(sim.world)  # model name -> its pose as the world file places it
        self._order = list(dict.fromkeys(_model_of(body.name) for body in sim.world.bodies))
        self._order += [car.model_name for car in sim.cars]
        self._spawned = 0
        self._vel = np.zeros(6)
        self._index()
        self.task = sim.scheduler.every(STATES_RATE, self._tick, "gazebo_ros_api_plugin", unheard=self._unheard)
        self._warn = ThrottledWarning(log, lambda: sim.time_ns)
        self.bus.subscribe(SET_MODEL_STATE, self._on_set_model_state, ModelState)
        for name, handler in (
            ("get_model_state", self.get_model_state),
            ("set_model_state", self.set_model_state),
            ("spawn_urdf_model", self.spawn_urdf_model),
            ("spawn_sdf_model", self.spawn_sdf_model),
            ("delete_model", self.delete_model),
            ("get_world_properties", self.get_world_properties),
            ("pause_physics", self.pause_physics),
            ("unpause_physics", self.unpause_physics),
            ("reset_simulation", self.reset_simulation),
            ("reset_world", self.reset_world),
        ):
            self.bus.advertise_service(f"{NAMESPACE}/{name}", handler)

    def _on_set_model_state(self, msg: ModelState) -> None:
        """The /gazebo/set_model_state topic; a message of another type is dropped with a throttled warning."""
        if type(msg) is not ModelState:
            self._warn(
                SET_MODEL_STATE,
                "%s: ignored a %s message (the topic takes %s)",
                SET_MODEL_STATE,
                type_name(msg),
                type_name(ModelState),
            )
            return
        self.set_model_state(SetModelStateRequest(msg))

    # --- the model table ---------------------------------------------------------------------------------------
    @property
    def model_names(self) -> list[str]:
        """Every model, in Gazebo's order: the world file's, then the cars, then what was spawned, by spawn time."""
        return list(self._order)

    def rebind(self, model: mujoco.MjModel, data: mujoco.MjData) -> None:
        """A model spawned or deleted: the model and link table is built again against the new model."""
        self._index()

    def close(self) -> None:
        """Stop publishing the state topics."""
        self.task.cancel()

    def _index(self) -> None:
        """(Re)build the table of models and links against the current MuJoCo model."""
        sim, model = self.sim, self.sim.model
        self._kin = mujoco.MjData(model)  # link poses: kinematics of the live qpos, the simulation's data untouched
        self._array_views: tuple[Any, ...] | None = None  # see _views()
        cars = {car.model_name: car for car in sim.cars}
        objects: dict[str, list[WorldBody]] = {}
        for body in sim.world.bodies:
            objects.setdefault(_model_of(body.name), []).append(body)
        self.models: dict[str, _Model] = {}
        for name in self._order:
            if name in cars:
                car = cars[name]
                root = car.state.body_id
                links = [
                    self._link(f"{name}::{car.names.local(model.body(b).name)}", b)
                    for b in np.flatnonzero(model.body_rootid == root).tolist()
                ]
                self.models[name] = _Model(name, links, car)
            elif name in objects:
                bodies = objects[name]
                links = [
                    self._link(
                        _link_name(body.name),
                        model.body(body.name).id if not body.static else -1,
                        (body.pos, body.quat),
                    )
                    for body in bodies
                ]
                canonical = (bodies[0].pos, bodies[0].quat)
                frame = self._frames.get(name, canonical)
                self.models[name] = _Model(name, links, offset=_between(canonical, frame), frame=frame, bodies=bodies)
        self._links = [link for m in self.models.values() for link in m.links]
        # Static models and links never move: their Pose and Twist objects are made once and shared by every message
        self._static_msgs = {link.name: (_pose_msg(*link.pose), Twist()) for link in self._links if link.body < 0}
        self._static_models = {
            m.name: (_pose_msg(*self._model_state(m)[0]), Twist())
            for m in self.models.values()
            if m.car is None and m.links[0].body < 0
        }
        # link_states() copies these lists and fills in only the moving links: (index, link) of those with a free
        # joint (their pose from qpos) and of the others (from the posed data, whose bodies `_posed_bodies` lists)
        self._link_names = [link.name for link in self._links]
        static = [self._static_msgs.get(link.name) for link in self._links]
        self._link_poses = [None if entry is None else entry[0] for entry in static]
        self._link_twists = [None if entry is None else entry[1] for entry in static]
        self._free_links = [(i, link) for i, link in enumerate(self._links) if link.body >= 0 and link.qpos >= 0]
        self._posed_links = [(i, link) for i, link in enumerate(self._links) if link.body >= 0 and link.qpos < 0]
        self._posed_bodies = np.array([link.body for _, link in self._posed_links], np.intp)  # a list costs 10x more
        # the moving links (free ones first, then posed ones), as link_arrays() gives their numbers
        moving = self._free_links + self._posed_links
        self._moving_rows = np.array([i for i, _ in moving], np.intp)
        self._moving_bodies = np.array([link.body for _, link in moving], np.intp)
        self._moving_roots = model.body_rootid[self._moving_bodies]
        self._free_qpos = np.array([link.qpos for _, link in self._free_links], np.intp)[:, None] + _FREE_POSE_ROS
        self._arrays = LinkArrays(self._free_qpos, self._posed_bodies, self._moving_bodies, self._moving_roots)
        # each car's row in link_arrays(): its base link (a free joint's body), whose state is the car model's
        free_rows = {link.body: row for row, (_, link) in enumerate(self._free_links)}
        self._base_rows = {
            m.name: free_rows[m.car.state.body_id]
            for m in self.models.values()
            if m.car is not None and m.car.state.body_id in free_rows
        }
        # the CDR layouts of the state messages (bytes for a recorder alone), with the names they were read off and
        # a message's numbers (the static links' and models' never change): made at the first such message
        self._link_shape: tuple[list[str], CdrLayout, np.ndarray] | None = None
        # (the model names, the layout, a message's numbers, the cars filled in from link_arrays() rows: _car_rows())
        self._model_shape: tuple[tuple[str, ...], CdrLayout, np.ndarray, tuple[np.ndarray, np.ndarray]] | None = None
        self._cars_from_rows: frozenset[int] = frozenset()
        # (the link names and models they were made for, what packs the link states, the model states): _tick
        self._packers: tuple[list[str], tuple[str, ...], FilledLayout, FilledLayout] | None = None

    def _link(self, name: str, body: int, static_pose: PoseArrays = _IDENTITY) -> _Link:
        model = self.sim.model
        if body < 0:
            return _Link(name, -1, (np.asarray(static_pose[0], float), np.asarray(static_pose[1], float)))
        link = _Link(name, body, static_pose)
        joint = model.body_jntadr[body]
        if model.body_jntnum[body] > 0 and model.jnt_type[joint] == mujoco.mjtJoint.mjJNT_FREE:
            link.qpos, link.dof = int(model.jnt_qposadr[joint]), int(model.jnt_dofadr[joint])
        return link

    # --- states --------------------------------------------------------------------------------------------------
    def _posed(self) -> mujoco.MjData:
        kin, data, model = self._kin, self.sim.data, self.sim.model
        for posed, live in self._views(data, kin, model)[1]:
            posed[:] = live
        mujoco.mj_kinematics(model, kin)
        return kin

    def _views(
        self, data: mujoco.MjData, kin: mujoco.MjData, model: mujoco.MjModel
    ) -> tuple[tuple[np.ndarray, ...], tuple[tuple[np.ndarray, np.ndarray], ...]]:
        """The arrays _state_arrays() reads (data's qpos, kin's xpos and xquat, data's xpos, subtree_com and cvel) and
        the (kin, data) pairs _posed() copies, as views made once per (data, kin, model): an MjData's arrays stay where
        they are for its lifetime, and each attribute read makes a new view."""
        made = self._array_views
        if made is None or made[0] is not data or made[1] is not kin or made[2] is not model:
            read = (data.qpos, kin.xpos, kin.xquat, data.xpos, data.subtree_com, data.cvel)
            copies: tuple[tuple[np.ndarray, np.ndarray], ...] = ((kin.qpos, data.qpos),)
            if model.nmocap:
                copies += ((kin.mocap_pos, data.mocap_pos), (kin.mocap_quat, data.mocap_quat))
            made = self._array_views = (data, kin, model, read, copies)
        return made[3], made[4]

    def _link_state(self, link: _Link, kin: mujoco.MjData | None) -> tuple[PoseArrays, PoseArrays]:
        """World pose and twist (linear, angular) of a link frame; `kin`: the posed private data, when needed."""
        if link.body < 0:
            return link.pose, _ZERO_TWIST
        data = self.sim.data
        if link.qpos >= 0:  # the raw free-joint coordinates, exactly what CarState.base_pose() hands the odometry
            q = data.qpos[link.qpos : link.qpos + 7]
            pose_ = (q[:3].copy(), q[3:].copy())
        else:
            kin = kin if kin is not None else self._posed()
            pose_ = (kin.xpos[link.body].copy(), kin.xquat[link.body].copy())
        mujoco.mj_objectVelocity(self.sim.model, data, mujoco.mjtObj.mjOBJ_XBODY, link.body, self._vel, 0)
        return pose_, (self._vel[3:].copy(), self._vel[:3].copy())

    def _model_state(self, m: _Model) -> tuple[PoseArrays, PoseArrays]:
        if m.car is not None:  # the odometry node's own calls: equal to /vesc/odom by construction
            return m.car.state.base_pose(), m.car.state.base_velocity()
        if m.links[0].body < 0:  # a static canonical link: the model stays where it was placed
            return m.frame, _ZERO_TWIST
        (pos, quat), twist = self._link_state(m.links[0], None)
        return compose(pos, quat, *m.offset), twist

    def _entity(self, name: str) -> tuple[PoseArrays, PoseArrays] | None:
        """Pose and twist of a model or a `model::link`, None if there is no such entity."""
        if name in self.models:
            return self._model_state(self.models[name])
        link = next((link for link in self._links if link.name == name), None)
        return None if link is None else self._link_state(link, None)

    def _unheard(self, _now_ns: int) -> bool:
        """Nobody listens to the state topics: then there is nothing to do."""
        return not (self.bus.has_listeners(LINK_STATES) or self.bus.has_listeners(MODEL_STATES))

    def _tick(self, now_ns: int) -> None:
        bus = self.bus
        packers = self._packers
        if (
            packers is not None
            and packers[0] is self._link_names
            and packers[1] == tuple(self.models)
            and self._bytes_alone(bus)
        ):  # only a recorder takes both: MuJoCo's arrays, as they are, and the writer packs both messages of them
            row = [self._state_arrays()]
            bus.publish_cdr_rows(LinkStates, packers[2], (LINK_STATES,), row)
            bus.publish_cdr_rows(ModelStates, packers[3], (MODEL_STATES,), row)
            return
        self._publish_states()
        if bus.cdr_only(LINK_STATES) and bus.cdr_only(MODEL_STATES):
            self._packers = self._filled_layouts()

    def _filled_layouts(self) -> tuple[list[str], tuple[str, ...], FilledLayout, FilledLayout] | None:
        """What packs the link and model states of link_arrays()' bytes (FilledLayout), once both layouts are read
        (and while the links and models they were read for stay); None where a model that is not a car moves (its
        state is not a row of link_arrays())."""
        link, model, models = self._link_shape, self._model_shape, tuple(self.models)
        if link is None or link[0] is not self._link_names or model is None or model[0] != models:
            return None
        car_models, car_rows = model[3]
        moving = {i for i, m in enumerate(self.models.values()) if m.name not in self._static_models}
        if moving != set(car_models.tolist()):
            return None
        pose, twist = np.arange(7), np.arange(6)
        rows, count, moving_links = self._moving_rows, len(self._link_names), len(self._moving_rows)
        link_fills = [  # LinkArrays.derive(): the moving links' poses (7 numbers each), then their twists (6)
            ((7 * rows[:, None] + pose).ravel(), 0, np.arange(7 * moving_links)),
            (7 * count + (6 * rows[:, None] + twist).ravel(), 1, np.arange(6 * moving_links)),
        ]
        at = 7 * len(models)
        model_fills = [
            ((7 * car_models[:, None] + pose).ravel(), 0, (7 * car_rows[:, None] + pose).ravel()),
            (at + (6 * car_models[:, None] + twist).ravel(), 1, (6 * car_rows[:, None] + twist).ravel()),
        ]
        return (
            self._link_names,
            models,
            FilledLayout(link[1], link[2], link_fills, self._arrays.derive),
            FilledLayout(model[1], model[2], model_fills, self._arrays.derive),
        )

    def _publish_states(self) -> None:
        """Both state topics, each as a message object or (a recorder its only taker) its bytes packed here."""
        bus = self.bus
        arrays = None  # link_arrays() of now, when the link states' bytes were made of them (the cars' rows: models)
        if bus.has_listeners(LINK_STATES):
            if bus.cdr_only(LINK_STATES):  # only a recorder takes it: its bytes, made from the numbers
                if self._link_shape is not None and self._link_shape[0] is self._link_names:
                    arrays = self.link_arrays()
                bus.publish_cdr(LINK_STATES, LinkStates, self._link_states_cdr(arrays))
            else:
                bus.publish(LINK_STATES, self.link_states())
        if bus.has_listeners(MODEL_STATES):
            if bus.cdr_only(MODEL_STATES):
                bus.publish_cdr(MODEL_STATES, ModelStates, self._model_states_cdr(arrays))
            else:
                bus.publish(MODEL_STATES, self.model_states())

    def _link_states_cdr(self, arrays: tuple[np.ndarray, np.ndarray] | None = None) -> bytes:
        """link_states() serialized, packed from its numbers: the static links' read off a first message made the
        object way (again when the links change), the moving links' from link_arrays() (`arrays`: those of now)."""
        shape = self._link_shape
        if shape is None or shape[0] is not self._link_names:
            msg = self.link_states()
            made = CdrLayout.of(msg)
            if made is None:  # not a shape a layout holds: the object's bytes
                return serialize(msg)
            self._link_shape = (self._link_names, made[0], np.array(made[1], float))
            return made[0].pack(made[1])
        _, layout, template = shape
        numbers = template.copy()  # every link's pose (7 numbers), then every link's twist (6)
        count = len(self._link_names)
        rows = self._moving_rows
        numbers[: 7 * count].reshape(count, 7)[rows], numbers[7 * count :].reshape(count, 6)[rows] = (
            self.link_arrays() if arrays is None else arrays
        )
        return layout.pack_doubles(numbers)

    def link_arrays(self) -> tuple[np.ndarray, np.ndarray]:
        """The moving links' poses (x, y, z, qx, qy, qz, qw) and twists (vx, vy, vz, wx, wy, wz) now, one row each in
        `_moving_rows` order (msgs.link_arrays.LinkArrays.of: free-joint links from qpos, the others from the posed
        data, the twists mj_objectVelocity's, bit for bit)."""
        data = self.sim.data
        kin = self._posed() if self._posed_links else data  # (without posed links, its xpos and xquat go unread)
        return self._arrays.of(data.qpos, kin.xpos, kin.xquat, data.xpos, data.subtree_com, data.cvel)

    def _state_arrays(self) -> tuple[bytes, ...]:
        """What link_arrays() reads, as bytes (LinkArrays.derive's row: msgs.link_arrays.STATE_ARRAYS)."""
        if self._posed_links:
            self._posed()
        qpos, kin_xpos, kin_xquat, xpos, subtree_com, cvel = self._views(self.sim.data, self._kin, self.sim.model)[0]
        # (without posed links, the posed data's xpos and xquat go unread)
        posed = (kin_xpos.tobytes(), kin_xquat.tobytes()) if self._posed_links else (b"", b"")
        return (qpos.tobytes(), *posed, xpos.tobytes(), subtree_com.tobytes(), cvel.tobytes())

    def _model_states_cdr(self, arrays: tuple[np.ndarray, np.ndarray] | None = None) -> bytes:
        """model_states() serialized, packed from its numbers (as _link_states_cdr): the cars' from base_odometry(), or
        from their base links' rows of `arrays` (link_arrays() of now: the same numbers, bit for bit), the other
        moving models' from _model_state(), the static ones' read off a first message."""
        models = tuple(self.models)
        shape = self._model_shape
        if shape is None or shape[0] != models:
            msg = self.model_states()
            made = CdrLayout.of(msg)
            if made is None:
                return serialize(msg)
            self._model_shape = (models, made[0], np.array(made[1], float), self._car_rows())
            return made[0].pack(made[1])
        _, layout, template, (car_models, car_rows) = shape
        numbers = template.copy()  # every model's pose (7 numbers), then every model's twist (6)
        count = len(models)
        done: frozenset[int] = frozenset()
        if arrays is not None and len(car_models):  # the cars' base links' rows: x y z qx qy qz qw, vx vy vz wx wy wz
            numbers[: 7 * count].reshape(count, 7)[car_models] = arrays[0][car_rows]
            numbers[7 * count :].reshape(count, 6)[car_models] = arrays[1][car_rows]
            done = self._cars_from_rows
        twist_at = 7 * count
        for i, m in enumerate(self.models.values()):
            if i in done or m.name in self._static_models:
                continue
            if m.car is not None:
                x, y, z, qw, qx, qy, qz, vx, vy, vz, wx, wy, wz = m.car.state.base_odometry()
                numbers[7 * i : 7 * i + 7] = x, y, z, qx, qy, qz, qw
                numbers[twist_at + 6 * i : twist_at + 6 * i + 6] = vx, vy, vz, wx, wy, wz
            else:
                (pos, quat), (linear, angular) = self._model_state(m)
                w, x, y, z = (float(v) for v in quat)
                numbers[7 * i : 7 * i + 7] = (*(float(v) for v in pos), x, y, z, w)
                numbers[twist_at + 6 * i : twist_at + 6 * i + 6] = (
                    *(float(v) for v in linear),
                    *(float(v) for v in angular),
                )
        return layout.pack_doubles(numbers)

    def _car_rows(self) -> tuple[np.ndarray, np.ndarray]:
        """The cars whose state is their base link's row of link_arrays(): their indices among the models, and the
        rows (kept as `_cars_from_rows` too, for the models the rows fill in)."""
        pairs = [(i, self._base_rows[m.name]) for i, m in enumerate(self.models.values()) if m.name in self._base_rows]
        self._cars_from_rows = frozenset(i for i, _ in pairs)
        return np.array([i for i, _ in pairs], np.intp), np.array([row for _, row in pairs], np.intp)

    def model_states(self) -> ModelStates:
        """Every model's pose and twist now, as /gazebo/model_states carries them."""
        msg = ModelStates()
        names, poses, twists = msg.name, msg.pose, msg.twist
        for m in self.models.values():
            if m.name in self._static_models:
                pose_msg, twist_msg = self._static_models[m.name]
            elif m.car is not None:  # _model_state()'s numbers, as Python floats in one call
                x, y, z, qw, qx, qy, qz, vx, vy, vz, wx, wy, wz = m.car.state.base_odometry()
                pose_msg = Pose(Point(x, y, z), Quaternion(qx, qy, qz, qw))
                twist_msg = Twist(Vector3(vx, vy, vz), Vector3(wx, wy, wz))
            else:
                pose_, twist = self._model_state(m)
                pose_msg, twist_msg = _pose_msg(*pose_), _twist_msg(*twist)
            names.append(m.name)
            poses.append(pose_msg)
            twists.append(twist_msg)
        return msg

    def link_states(self) -> LinkStates:
        """Every link's pose and twist now, as /gazebo/link_states carries them. A static link's Pose and Twist
        objects are shared by every message (they never change); the moving links' numbers are link_arrays()'."""
        poses, twists = self._link_poses.copy(), self._link_twists.copy()
        moving_poses, moving_twists = self.link_arrays()
        for i, (px, py, pz, x, y, z, w), (vx, vy, vz, wx, wy, wz) in zip(
            self._moving_rows.tolist(), moving_poses.tolist(), moving_twists.tolist()
        ):
            poses[i] = Pose(Point(px, py, pz), Quaternion(x, y, z, w))
            twists[i] = Twist(Vector3(vx, vy, vz), Vector3(wx, wy, wz))
        # every None of the templates was a moving link's, filled in above
        return LinkStates(self._link_names.copy(), cast(list[Pose], poses), cast(list[Twist], twists))

    # --- services: state -------------------------------------------------------------------------------------
    def get_model_state(self, req: GetModelStateRequest) -> GetModelStateResponse:
        """A model's pose and twist, in the world or relative to `relative_entity_name` (a model or model::link):
        pose = model - frame, twist = the frame's rotation applied backwards to (model - frame) velocities."""
        res = GetModelStateResponse(Header.at(self.sim.time_ns, req.relative_entity_name))
        if req.model_name not in self.models:
            res.status_message = f"GetModelState: model [{req.model_name}] does not exist ({self._known()})"
            return res
        (pos, quat), (lin, ang) = self._model_state(self.models[req.model_name])
        frame = self._entity(req.relative_entity_name)
        if frame is not None:
            (fpos, fquat), (flin, fang) = frame
            back = quat_to_matrix(fquat).T
            pos, quat = back @ (pos - fpos), quat_mul(_conj(fquat), quat)
            lin, ang = back @ (lin - flin), back @ (ang - fang)
        elif req.relative_entity_name not in WORLD_FRAMES:
            res.status_message = (
                f"GetModelState: reference relative_entity_name [{req.relative_entity_name}] not "
                "found, did you forget to scope the body by model name?"
            )
            return res
        res.pose, res.twist = _pose_msg(pos, quat), _twist_msg(lin, ang)
        res.success, res.status_message = True, "GetModelState: got properties"
        return res

    def set_model_state(self, req: SetModelStateRequest) -> SetModelStateResponse:
        """Teleport a model (a car or a free object): pose and twist in the world or in `reference_frame`. Every
        link moves rigidly with the model and takes the twist (a car's wheels and hinges keep their angles and stop
        turning relative to it). Static models cannot be moved here (their geometry is welded into the world)."""
        state = req.model_state
        res = SetModelStateResponse()
        m = self.models.get(state.model_name)
        if m is None:
            res.status_message = f"SetModelState: model [{state.model_name}] does not exist ({self._known()})"
            return res
        pos = np.array([state.pose.position.x, state.pose.position.y, state.pose.position.z], float)
        o = state.pose.orientation
        quat = _normalized(np.array([o.w, o.x, o.y, o.z], float))
        lin = np.array([state.twist.linear.x, state.twist.linear.y, state.twist.linear.z], float)
        ang = np.array([state.twist.angular.x, state.twist.angular.y, state.twist.angular.z], float)
        if not all(np.isfinite(v).all() for v in (pos, quat, lin, ang)):
            res.status_message = "SetModelState: the pose and twist must be finite numbers"
            return res
        frame = self._entity(state.reference_frame)
        if frame is not None:
            (fpos, fquat), _ = frame
            pos, quat = compose(fpos, fquat, pos, quat)
            lin, ang = quat_rotate(fquat, lin), quat_rotate(fquat, ang)
        elif state.reference_frame not in WORLD_FRAMES:
            res.status_message = (
                f"SetModelState: specified reference frame entity [{state.reference_frame}] does not exist"
            )
            return res
        if not m.movable:
            res.status_message = (
                f"SetModelState: model [{m.name}] is static: its geometry is part of the world and cannot be moved"
            )
            return res
        self._teleport(m, (pos, quat), lin, ang)
        res.success, res.status_message = True, "SetModelState: set model state done"
        return res

    def _teleport(self, m: _Model, target: PoseArrays, lin: np.ndarray, ang: np.ndarray) -> None:
        model, data = self.sim.model, self.sim.data
        now_inv = _inverse(self._model_state(m)[0])
        kin = self._posed()
        moves = [
            (link, compose(*target, *compose(*now_inv, *self._link_state(link, kin)[0])))
            for link in m.links
            if link.qpos >= 0
        ]
        if m.car is not None:  # the car's own joints stop turning relative to it
            root = m.car.state.body_id
            inside = model.body_rootid[model.dof_bodyid] == root
            data.qvel[inside] = 0.0
        for link, (pos, quat) in moves:
            data.qpos[link.qpos : link.qpos + 3] = pos
            data.qpos[link.qpos + 3 : link.qpos + 7] = _normalized(quat)
            data.qvel[link.dof : link.dof + 3] = lin
            data.qvel[link.dof + 3 : link.dof + 6] = quat_to_matrix(quat).T @ ang  # a free joint's spin is local
        mujoco.mj_forward(model, data)
        self.sim.poses_changed()

    def get_world_properties(self, req: GetWorldPropertiesRequest) -> GetWorldPropertiesResponse:
        """Sim time and the model names (gazebo_msgs/GetWorldProperties)."""
        rendering = any(car.camera is not None for car in self.sim.cars)
        return GetWorldPropertiesResponse(
            self.sim.time, self.model_names, rendering, True, "GetWorldProperties: got properties"
        )

    # --- services: physics ------------------------------------------------------------------------------------
    def pause_physics(self, req: EmptyRequest | None = None) -> EmptyResponse:
        """Stop the physics: sim time stands still (run_until returns at once) until unpause_physics."""
        self.sim.paused = True
        return EmptyResponse()

    def unpause_physics(self, req: EmptyRequest | None = None) -> EmptyResponse:
        """Let sim time run again."""
        self.sim.paused = False
        return EmptyResponse()

    def reset_simulation(self, req: EmptyRequest | None = None) -> EmptyResponse:
        """World::Reset: sim time back to 0 and every model at its initial pose - Simulator.reset(), which keeps
        every node (asked during an event, it happens once that event is over). Spawned models stay, at the pose
        they were spawned at; deleted ones stay deleted; a pause stays."""
        self.sim.defer(self.sim.reset)
        return EmptyResponse()

    def reset_world(self, req: EmptyRequest | None = None) -> EmptyResponse:
        """World::ResetEntities(MODEL): every model back at its initial pose, at rest, its controllers' state and
        set points cleared (as the model plugins' Reset does) - and sim time goes on: no timer restarts, the muxes
        keep what they hold, the on_reset hooks do not run."""
        model, data = self.sim.model, self.sim.data
        time = data.time
        mujoco.mj_resetData(model, data)
        data.qpos[:] = model.qpos0
        data.time = time
        mujoco.mj_forward(model, data)
        self.sim.poses_changed()
        return EmptyResponse()

    # --- services: spawn and delete -----------------------------------------------------------------------------
    def spawn_urdf_model(self, req: SpawnModelRequest) -> SpawnModelResponse:
        """Add a car from URDF XML (e.g. `expand_xacro(DEFAULT_XACRO)`) at `initial_pose`, with its nodes under
        `robot_namespace` (default: the model name): it drives through its own
        `/<ns>/vesc/ackermann_cmd_mux/input/navigation`. Its Gazebo model name is the one its namespace gives
        (`model_name` must be that: our cars derive every name from the namespace). Profile, controllers, sensors
        and odometry mode are the first car's; the URDF is used as given (the profile's xacro arguments cannot
        apply to an expanded URDF). A spawn pose inside an obstacle or another car, or with no ground below, fails
        as it does at start-up."""
        if _root_tag(req.model_xml) != "robot":
            return SpawnModelResponse(
                False, "SpawnModel: Failure - entity format is invalid (spawn_urdf_model takes a URDF: <robot>)."
            )
        return self._spawn_car(req)

    def spawn_sdf_model(self, req: SpawnModelRequest) -> SpawnModelResponse:
        """Add a world object from SDF XML (`<sdf><model>...` or `<sdf><include>`, read by the world loader): its
        pose is `initial_pose` (in `reference_frame`) times the model's own <pose>; `model_name` renames it. A
        static model joins the world's fixed geometry, a free one is pushable. A URDF goes to spawn_urdf_model, as
        gazebo_ros does."""
        tag = _root_tag(req.model_xml)
        if tag == "robot":
            return self._spawn_car(req)
        if tag != "sdf":
            return SpawnModelResponse(False, "SpawnModel: Failure - input model_xml not SDF or URDF")
        return self._spawn_object(req)

    def delete_model(self, req: DeleteModelRequest) -> DeleteModelResponse:
        """Remove a model: a world object (free or static), or a car with its nodes (their timers, subscriptions
        and services go; its /tf_static entries stay latched). The last car cannot be deleted."""
        m = self.models.get(req.model_name)
        if m is None:
            return DeleteModelResponse(False, f"DeleteModel: model [{req.model_name}] does not exist ({self._known()})")
        sim = self.sim
        if m.car is not None:
            if len(sim.cars) == 1:
                return DeleteModelResponse(False, f"DeleteModel: [{m.name}] is the last car; a Simulator keeps one")
            self._order.remove(m.name)
            sim.delete_car(m.car)
        else:
            self._order.remove(m.name)
            sim.remove_world_bodies(m.bodies)
        return DeleteModelResponse(True, "DeleteModel: successfully deleted model")

    def _initial_pose(self, req: SpawnModelRequest) -> PoseArrays | str:
        p, o = req.initial_pose.position, req.initial_pose.orientation
        pose_ = (np.array([p.x, p.y, p.z], float), _normalized(np.array([o.w, o.x, o.y, o.z], float)))
        if not (np.isfinite(pose_[0]).all() and np.isfinite(pose_[1]).all()):
            return "SpawnModel: initial_pose must be finite numbers"
        frame = self._entity(req.reference_frame)
        if frame is not None:
            return compose(*frame[0], *pose_)
        if req.reference_frame not in WORLD_FRAMES:
            return "SpawnModel: reference reference_frame not found, did you forget to scope the link by model name?"
        return pose_

    def _spawn_car(self, req: SpawnModelRequest) -> SpawnModelResponse:
        sim = self.sim
        initial = self._initial_pose(req)
        if isinstance(initial, str):
            return SpawnModelResponse(False, initial)
        namespace = req.robot_namespace.strip("/") or (req.model_name if req.model_name != CarNames().model else "")
        try:
            names = CarNames(namespace)
        except RacecarSimError as exc:
            return SpawnModelResponse(False, f"SpawnModel: {exc}")
        name = req.model_name or names.model
        if name != names.model:
            return SpawnModelResponse(
                False,
                f"SpawnModel: a car's model name is its namespace's: robot_namespace "
                f"'{namespace}' gives model [{names.model}], not [{name}]",
            )
        if name in self.models or any(car.name == namespace for car in sim.cars):
            return SpawnModelResponse(False, f"SpawnModel: Failure - entity [{name}] already exists.")
        (pos, quat) = initial
        x, y, z = (float(v) for v in pos)
        first = sim.cars[0]
        car = Car(
            namespace,
            profile=first.profile_name,
            controllers=first.controllers_file,
            spawn=Spawn(x, y, z, yaw_of(quat)),
            sensors_off=first.off,
            odometry=first.odometry_mode,
        )
        car.urdf = req.model_xml
        try:
            car.load()
        except RacecarSimError as exc:
            return SpawnModelResponse(False, f"SpawnModel: {exc}")
        self._order.append(name)  # before the rebuild: the model table is indexed with it
        try:
            sim.spawn_car(car, quat)  # the full orientation, not only the heading
        except (RacecarSimError, ValueError) as exc:
            self._order.remove(name)
            return SpawnModelResponse(False, f"SpawnModel: {exc}")
        log.info("spawned car %s at (%.3g, %.3g, %.3g)", name, *pos)
        return SpawnModelResponse(True, "SpawnModel: Successfully spawned entity")

    def _spawn_object(self, req: SpawnModelRequest) -> SpawnModelResponse:
        sim = self.sim
        initial = self._initial_pose(req)
        if isinstance(initial, str):
            return SpawnModelResponse(False, initial)
        try:
            name, frame, bodies = _load_model(req.model_xml, req.model_name, initial)
        except RacecarSimError as exc:
            return SpawnModelResponse(False, f"SpawnModel: {exc}")
        if name in self.models:
            return SpawnModelResponse(False, f"SpawnModel: Failure - entity [{name}] already exists.")
        if not bodies:
            return SpawnModelResponse(False, f"SpawnModel: model [{name}] has no link")
        self._spawned += 1
        self._frames[name] = frame
        self._order.append(name)
        try:
            sim.add_world_bodies(bodies, f"gazebo_spawn{self._spawned}/")
        except RacecarSimError as exc:
            self._order.remove(name)
            del self._frames[name]
            return SpawnModelResponse(False, f"SpawnModel: {exc}")
        return SpawnModelResponse(True, "SpawnModel: Successfully spawned entity")

    def _known(self) -> str:
        return "models: " + ", ".join(self._order)


# --- helpers -----------------------------------------------------------------------------------------------------
def _model_of(body_name: str) -> str:
    """The Gazebo model a world link belongs to: `cone_1::link` -> `cone_1`; a map's `map` body -> `map`."""
    return body_name.split("::", 1)[0]


def _link_name(body_name: str) -> str:
    return body_name if "::" in body_name else f"{body_name}::link"


def _pose_msg(pos: np.ndarray, quat: np.ndarray) -> Pose:
    w, x, y, z = (float(v) for v in quat)  # as the odometry node converts them
    return Pose(Point(*(float(v) for v in pos)), Quaternion(x, y, z, w))


def _twist_msg(linear: np.ndarray, angular: np.ndarray) -> Twist:
    return Twist(Vector3(*(float(v) for v in linear)), Vector3(*(float(v) for v in angular)))


def _conj(q: np.ndarray) -> np.ndarray:
    return np.array([q[0], -q[1], -q[2], -q[3]])


def _normalized(q: np.ndarray) -> np.ndarray:
    norm = float(np.linalg.norm(q))
    return q / norm if norm > 0 else np.array([1.0, 0.0, 0.0, 0.0])  # ignition: a zero quaternion is the identity


def _inverse(p: PoseArrays) -> PoseArrays:
    q = _conj(_normalized(p[1]))
    return -quat_rotate(q, p[0]), q


def _between(a: PoseArrays, b: PoseArrays) -> PoseArrays:
    """The pose of frame b in frame a: a * result = b."""
    return compose(*_inverse(a), *b)


def _root_tag(xml: str) -> str | None:
    try:
        return ET.fromstring(xml.strip()).tag
    except ET.ParseError:
        return None


def _world_file_frames(world: World) -> dict[str, PoseArrays]:
    """Top-level model poses as the world's SDF file places them (an <include>'s pose replacing the model's own);
    {} for worlds made from maps or tracks. A model missing here is placed at its first link."""
    path = Path(world.source) if world.source else None
    if path is None or path.suffix.lower() not in (".world", ".sdf") or not path.is_file():
        return {}
    frames: dict[str, PoseArrays] = {}
    with warnings.catch_warnings():  # the loader has said it all already
        warnings.simplefilter("ignore")
        try:
            world_el = ET.parse(path).getroot().find("world")
        except ET.ParseError:
            return {}
        ctx = SdfContext(path, [])
        for el in [] if world_el is None else world_el:
            try:
                if el.tag == "model":
                    frames[el.get("name", "model")] = pose_or_identity(el, ctx, "model")
                elif el.tag == "include":
                    name, placed = (el.findtext("name") or "").strip(), pose(el, ctx, "include")
                    if not name or placed is None:
                        folder = resolve_uri(el.findtext("uri") or "", ctx, "include")
                        inner = ET.parse(folder if folder.is_file() else folder / "model.sdf").getroot().find("model")
                        if inner is None:
                            continue
                        name = name or inner.get("name", "model")
                        placed = placed or pose_or_identity(inner, ctx, "model")
                    frames[name] = placed
            except (WorldError, OSError, ET.ParseError):
                continue
    return frames


def _load_model(xml: str, model_name: str, initial: PoseArrays) -> tuple[str, PoseArrays, list[WorldBody]]:
    """Read spawn_sdf_model's XML with the world loader: (name, model pose, links). As gazebo_ros does, the model
    is renamed to `model_name` (when given) and placed at initial * its own pose."""
    root = ET.fromstring(xml.strip())
    target = root.find("model")
    if target is None:
        target = root.find("include")
    if target is None:
        target = root.find("world/include")
    if target is None:
        raise WorldError("spawn_sdf_model needs <sdf><model> or <sdf><include> (lights are not spawned)")
    ctx = SdfContext(Path("spawn_sdf_model"), [])
    own = pose(target, ctx, "the spawned model") or _IDENTITY
    if target.tag == "model":
        name = model_name or target.get("name", "model")
        target.set("name", name)
        placed = compose(*initial, *own)
    else:
        name = model_name or (target.findtext("name") or "").strip()
        if not name:
            folder = resolve_uri(target.findtext("uri") or "", ctx, "<include>")
            inner = ET.parse(folder if folder.is_file() else folder / "model.sdf").getroot().find("model")
            name = "model" if inner is None else inner.get("name", "model")
        for old in target.findall("name"):
            target.remove(old)
        ET.SubElement(target, "name").text = name
        placed = compose(*initial, *own)  # an include without a pose: Gazebo places it at initial_pose
    for old in target.findall("pose"):
        target.remove(old)
    pos, quat = placed
    pose_el = ET.SubElement(target, "pose", rotation_format="quat_xyzw")
    pose_el.text = " ".join(repr(float(v)) for v in (*pos, quat[1], quat[2], quat[3], quat[0]))
    sdf = ET.Element("sdf", version=root.get("version", "1.6"))
    ET.SubElement(sdf, "world", name="spawn_sdf_model").append(target)
    with tempfile.TemporaryDirectory() as temp:
        path = Path(temp) / f"{name}.sdf"
        path.write_text(ET.tostring(sdf, encoding="unicode"))
        world = load_sdf(path)
    return name, placed, world.bodies
