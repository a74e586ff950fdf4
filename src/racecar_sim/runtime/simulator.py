"""The Simulator: a world, its cars, the nodes of the original stack on one bus, and a sim clock.

Physics runs inside MuJoCo for as many steps as fit before the next event (a sensor sample, a node's
timer, a mux timeout); Python runs only at those events. The bus, the scheduler, the model and every node
live as long as the Simulator: reset() restores the physics and calls reset hooks, it rebuilds nothing.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import mujoco

from racecar_sim.bus import Bus, Subscription
from racecar_sim.core.errors import ConfigError, PhysicsError
from racecar_sim.core.names import CLOCK
from racecar_sim.core.rng import check_seed
from racecar_sim.runtime.scheduler import Scheduler
from racecar_sim.core.throttle import is_finite_number
from racecar_sim.core.time import NS_PER_S, ceil_to_step, to_ns
from racecar_sim.description import DEFAULT_XACRO
from racecar_sim.msgs import Clock, String, Time
from racecar_sim.physics import (NearWalls, check_spawn, fit_near_walls, load_preset, route_mujoco_warnings,
                                 world_spec)
from racecar_sim.physics.builder import friction_min_rule
from racecar_sim.physics.car_contacts import CarContacts
from racecar_sim.physics.world_geoms import mujoco_rejected
from racecar_sim.runtime.car import Car
from racecar_sim.runtime.gazebo_api import GazeboApi
from racecar_sim.sensors.robot_state import StaticTransforms
from racecar_sim.worlds import DEFAULT_WALL_HEIGHT, Spawn, World, load_world

if TYPE_CHECKING:
    from racecar_sim.recording import McapRecorder

log = logging.getLogger("racecar_sim")
_DIVERGENCE_WARNINGS = (mujoco.mjtWarning.mjWARN_BADQPOS, mujoco.mjtWarning.mjWARN_BADQVEL,
                        mujoco.mjtWarning.mjWARN_BADQACC)
_BADQPOS, _BADQVEL, _BADQACC = (int(kind) for kind in _DIVERGENCE_WARNINGS)  # plain ints index numpy fastest
CLOCK_RATE = 100.0  # gazebo_ros publishes /clock at pub_clock_frequency, 100 Hz by default
COLLISIONS = "/racecar_sim/collisions"  # std_msgs/String "carA carB" when two cars start touching


@dataclass(frozen=True)
class Collision:
    """Two cars started touching at sim time `time_ns` (names: namespaces, "racecar" for the unnamed car)."""

    time_ns: int
    cars: tuple[str, str]


class Simulator:
    """RACECARs in one world: one car with the original names by default, or a fleet given as `cars`.

    >>> sim = Simulator(world="empty", profile="seed", seed=0)
    >>> sim.publish("/vesc/ackermann_cmd_mux/input/navigation", AckermannDriveStamped(drive=AckermannDrive(speed=1.0)))
    >>> sim.run_until(2.0)

    >>> fleet = Simulator(world="tunnel", cars=[Car("car1"), Car("car2", spawn=Spawn(-1.5, 0, 0.05, 0))])

    Every topic of the original is on `sim.bus` under its original name, each car's under its namespace; Gazebo's
    own (/gazebo/model_states, /gazebo/link_states and the /gazebo/* services: get/set_model_state, spawn_urdf_model,
    spawn_sdf_model, delete_model, pause/unpause_physics, reset_simulation/reset_world) come from `sim.gazebo`.
    Same world, cars, seed and inputs give bit-identical messages.

    `near_walls` (default on): a world body of many wall boxes (a map) is held out of MuJoCo's collision model and
    only the boxes within reach of each car or free body are placed in it (physics.near_walls; the same contacts
    at a fraction of the cost); off, every box is a geom.
    """

    def __init__(self, world: str | World = "empty", profile: str = "seed", seed: int = 0, physics: str = "default",
                 spawn: Spawn | None = None, odometry: str = "original", xacro: str | Path = DEFAULT_XACRO,
                 xacro_args: Mapping[str, str] | None = None, controllers: str | Path | None = None,
                 model_path: list[str | Path] | None = None, wall_height: float = DEFAULT_WALL_HEIGHT,
                 lidar: bool = True, camera: bool = True, sensor_noise: bool = True,
                 cars: Sequence[Car] | None = None, near_walls: bool = True) -> None:
        self.seed = check_seed(seed)
        self.sensor_noise = sensor_noise
        if cars is None:
            cars = [Car("", xacro, xacro_args, profile, controllers, spawn, lidar, camera, odometry)]
        else:
            given = [name for name, value, default in (
                ("profile", profile, "seed"), ("spawn", spawn, None), ("odometry", odometry, "original"),
                ("xacro", xacro, DEFAULT_XACRO), ("xacro_args", xacro_args, None), ("controllers", controllers, None),
                ("lidar", lidar, True), ("camera", camera, True)) if value != default]
            if given:
                raise ConfigError(f"with cars=[...], give {', '.join(given)} to each Car, not to the Simulator")
        self.cars = _checked_fleet(cars)
        for index, car in enumerate(self.cars):
            car.load(self.cars[index - 1] if index else None)  # a fleet of identical cars expands the xacro once
        first = self.cars[0]
        if isinstance(world, World):
            self.world = world
        else:
            self.world = load_world(world, first.spawn, [Path(p) for p in model_path or []], wall_height)
        if first.spawn is not None:
            self.world.spawn = first.spawn
        self.spawns = [car.spawn or self.world.spawn for car in self.cars]
        self.preset = load_preset(physics)
        route_mujoco_warnings()
        spec = world_spec(self.world, self.preset, near_walls)
        spec.modelname = first.robot.name if len(self.cars) == 1 else self.world.name or "fleet"
        for car, car_spawn in zip(self.cars, self.spawns):
            car.add_to(spec, self.preset, car_spawn, rank_friction=False)
        friction_min_rule(spec)  # once for the whole fleet: once per car costs N² (every geom of the cars before)
        try:
            self.model = spec.compile()
            if fit_near_walls(spec, self.model):
                self.model = spec.compile()
        except ValueError as exc:  # one line, blaming the world file's model or else the car's xacro
            raise mujoco_rejected(exc, self.world, first.xacro) from None
        self.spec = spec  # kept: models spawned or deleted at run time change it, and it is recompiled
        self.data = mujoco.MjData(self.model)
        self.step_ns = to_ns(self.model.opt.timestep)
        if abs(self.step_ns / NS_PER_S - self.model.opt.timestep) > 1e-15:
            raise ConfigError(f"physics step {self.model.opt.timestep} s is not a whole number of nanoseconds")
        mujoco.mj_forward(self.model, self.data)
        # a map's walls near the cars (physics.near_walls): placed before the spawn check, which looks at them
        self.near_walls = NearWalls.of(self.model, self.data)
        for car, car_spawn in zip(self.cars, self.spawns):  # WorldError: inside an obstacle or a car, no ground
            check_spawn(self.model, self.data, self.world, car.robot, car.names, car_spawn)
        self._qpos0 = self.data.qpos.copy()
        self._recorders: list[McapRecorder] = []
        self._reset_hooks: list[Callable[[], None]] = []
        self._collision_hooks: list[Callable[[Collision], None]] = []
        self._divergence: str | None = None
        self._rebuild_hooks: list[Callable[[mujoco.MjModel, mujoco.MjData], None]] = []
        self._deferred: list[Callable[[], None]] = []
        self._in_event = False
        self.paused = False
        self.time_ns = 0
        self.bus = Bus()
        self.scheduler = Scheduler(self.step_ns)
        self._near_walls_look = self.scheduler.timeout(lambda _now: self.poses_changed(), "near_walls")
        self.poses_changed()
        self.static_tf = StaticTransforms(self.bus)
        self.scheduler.every(CLOCK_RATE, self._publish_clock, "clock", unheard=self._unheard_clock)
        now = lambda: self.time_ns  # noqa: E731
        for car in self.cars:
            car.start(self.model, self.data, self.bus, self.scheduler, now, self.static_tf, self.seed, sensor_noise)
        self._contacts = CarContacts(self.model, [car.state.body_id for car in self.cars]) if len(self.cars) > 1 else None
        self._touching: set[tuple[int, int]] = set()
        self.gazebo = GazeboApi(self)  # /gazebo/link_states, /gazebo/model_states and the /gazebo/* services

    # --- the first car, under the names the single-car API always had ---------------------------------
    @property
    def car(self) -> Car:
        """The first car (the only one unless `cars` was given)."""
        return self.cars[0]

    robot = property(lambda self: self.car.robot, doc="The first car's parsed URDF.")
    profile = property(lambda self: self.car.profile, doc="The first car's driving profile.")
    controllers = property(lambda self: self.car.controllers, doc="The first car's controller configuration.")
    state = property(lambda self: self.car.state, doc="The first car's state access.")
    commands = property(lambda self: self.car.commands, doc="The first car's controller command node.")
    controller_manager = property(lambda self: self.car.controller_manager, doc="The first car's controller_manager.")
    chain = property(lambda self: self.car.chain, doc="The first car's ackermann_cmd_mux chain.")
    servo = property(lambda self: self.car.servo, doc="The first car's servo_commands node.")
    joint_states = property(lambda self: self.car.joint_states, doc="The first car's joint_state_controller.")
    robot_state = property(lambda self: self.car.robot_state, doc="The first car's robot_state_publisher.")
    odometry = property(lambda self: self.car.odometry, doc="The first car's odometry node.")
    lidar = property(lambda self: self.car.lidar, doc="The first car's lidar (None when off).")
    camera = property(lambda self: self.car.camera, doc="The first car's camera (None when off).")
    controllers_file = property(lambda self: self.car.controllers_file, doc="The first car's controller YAML.")

    def car_named(self, name: str) -> Car:
        """A car by its namespace (or its Gazebo model name: `racecar` for the unnamed car)."""
        for car in self.cars:
            if name in (car.name, car.model_name):
                return car
        raise KeyError(f"no car named {name!r} (cars: {', '.join(c.model_name for c in self.cars)})")

    # --- the public API -------------------------------------------------------------------------
    @property
    def time(self) -> float:
        """Sim time in seconds."""
        return self.time_ns / NS_PER_S

    def publish(self, topic: str, msg: Any) -> None:
        """Publish on the bus now (at the current sim time)."""
        self.bus.publish(topic, msg)

    def subscribe(self, topic: str, callback: Callable[[Any], None], msgtype: type | None = None) -> Subscription:
        """Call `callback(msg)` for every message on `topic` (the bus lives as long as the Simulator).

        `msgtype` declares the message class taken, so that a ROS bridge subscribes to the topic on the ROS side.
        """
        return self.bus.subscribe(topic, callback, msgtype)

    def on_reset(self, hook: Callable[[], None]) -> None:
        """Call `hook()` after every reset(), once the physics is back at its start (a driver clears its state)."""
        self._reset_hooks.append(hook)

    def on_collision(self, hook: Callable[[Collision], None]) -> None:
        """Call `hook(Collision)` when two cars start touching (checked at every event, not every physics step)."""
        self._collision_hooks.append(hook)

    @property
    def paused(self) -> bool:
        """Whether the physics is paused (/gazebo/pause_physics): sim time stands still until unpaused."""
        return self._paused

    @paused.setter
    def paused(self, value: bool) -> None:
        self._paused, self._pause_told = bool(value), False

    def poses_changed(self) -> None:
        """Models were moved by hand (a reset, a teleport; mj_forward done): bring up to date what depends on where
        they are: the map walls within reach of each car (physics.near_walls, which also says when to look again)."""
        if self.near_walls is not None:
            self._near_walls_look.restart(self.time_ns + to_ns(self.near_walls.refresh()))

    def on_rebuild(self, hook: Callable[[mujoco.MjModel, mujoco.MjData], None]) -> None:
        """Call `hook(model, data)` when a model spawned or deleted at run time replaced `sim.model` and `sim.data`
        (the Simulator's own nodes are rebound already; a user's node holding the old ones should take these)."""
        self._rebuild_hooks.append(hook)

    def defer(self, action: Callable[[], None]) -> None:
        """Run `action()` once the event being handled is over (at once outside of run_until): what moves sim
        time (reset) must not happen while the scheduler is firing the tasks due now."""
        if self._in_event:
            self._deferred.append(action)
        else:
            action()

    def run_until(self, t: float) -> None:
        """Advance sim time to `t` seconds (rounded up to a physics step), firing every event on the way.

        While the physics is paused (/gazebo/pause_physics) sim time stands still, as in a paused Gazebo: nothing
        steps, no timer fires, nothing publishes, and run_until returns at once (logging it once per pause); a loop
        that waits for sim time must call /gazebo/unpause_physics. A pause asked for during an event stops the run
        after that event.
        """
        end = ceil_to_step(to_ns(t), self.step_ns)
        if self._divergence is not None:
            raise PhysicsError(self._divergence)
        if self._paused:
            if not self._pause_told and self.time_ns < end:
                log.warning("the physics is paused (/gazebo/pause_physics): sim time stays at %.3f s until "
                            "/gazebo/unpause_physics", self.time)
                self._pause_told = True
            return
        scheduler, step, counted, warnings = self.scheduler, mujoco.mj_step, None, None
        while self.time_ns < end and not self._paused:
            # tasks whose messages nobody would receive run without a stop; a fleet stops at each for its contacts
            due = scheduler.next_time(end if self._contacts is None else None)
            target = end if due is None else max(min(due, end), self.time_ns)
            if target > self.time_ns:
                data = self.data  # a model spawned or deleted in an event replaces it
                step(self.model, data, nstep=(target - self.time_ns) // self.step_ns)
                self.time_ns = target
                if data is not counted:
                    counted, warnings = data, data.warning.number  # a live view of MuJoCo's warning counters
                if warnings[_BADQPOS] or warnings[_BADQVEL] or warnings[_BADQACC]:  # _check_physics's cheap look
                    self._check_physics()
                if self._contacts is not None:
                    self._check_collisions()
            self._in_event = True
            try:
                scheduler.run_due(self.time_ns)
            finally:
                self._in_event = False
            while self._deferred:
                self._deferred.pop(0)()

    def run_for(self, duration: float) -> None:
        """Advance sim time by `duration` seconds."""
        self.run_until(self.time + duration)

    def reset(self, seed: int | None = None, spawn: Spawn | Mapping[str, Spawn] | Sequence[Spawn] | None = None) -> None:
        """Back to t = 0 with every car at its spawn pose (or at `spawn`: one pose for the first car, a pose per
        car in order, or a mapping of car names to poses), and a new noise `seed` if given.

        Nothing is rebuilt: subscriptions, timers, recorders, bridges and every node stay attached; each car's
        muxes go idle, its sensors take the seed, and the hooks given to on_reset() run. Asked for from inside an
        event (a callback or a timer), the reset happens once that event is over, and a run_until in progress
        then goes on on the new clock, to its target time.

        A pose given is checked as the constructor checks spawns (a WorldError if the car would be inside an
        obstacle or another car, or have no ground under it; a ConfigError for a pose that is not finite numbers);
        refused, the reset does not happen: the sim is left as it was.
        """
        new_seed = self.seed if seed is None else check_seed(seed)
        poses = _spawn_poses(self, spawn)  # a malformed pose is refused at once, even from inside an event
        if self._in_event:
            self.defer(lambda: self.reset(seed, spawn))
            return
        seed = new_seed
        saved = self._backup() if poses else None  # to put back if a pose is refused
        self.car.state.reset(self._qpos0)
        for index, pose in poses.items():
            self.cars[index].state.set_base_pose(pose.x, pose.y, pose.z, pose.yaw)
        mujoco.mj_forward(self.model, self.data)
        if poses:
            self._check_spawns(poses, saved)
        self.seed = seed
        self.time_ns = 0
        self._divergence = None
        self._touching = set()
        self.scheduler.reset()
        self.poses_changed()
        for car in self.cars:
            car.reset(self.seed)
        for hook in self._reset_hooks:
            hook()

    def _backup(self) -> mujoco.MjData:
        """The physics state copied into an MjData kept for it (made on first use, and again for a new model)."""
        backup = getattr(self, "_reset_backup", None)
        if backup is None or backup[0] is not self.model:
            backup = self._reset_backup = (self.model, mujoco.MjData(self.model))
        mujoco.mj_copyData(backup[1], self.model, self.data)
        return backup[1]

    def _check_spawns(self, poses: dict[int, Spawn], saved: mujoco.MjData) -> None:
        """check_spawn for each car put at a pose of reset(), with the map walls near it in place; on refusal the
        physics state (and the near walls) go back to `saved`, and the error is raised."""
        try:
            if self.near_walls is not None:
                self.near_walls.refresh()
            for index, pose in poses.items():
                car = self.cars[index]
                check_spawn(self.model, self.data, self.world, car.robot, car.names, pose)
        except Exception:
            mujoco.mj_copyData(self.data, self.model, saved)
            if self.near_walls is not None:
                self.near_walls.refresh()
            raise

    def record(self, path: str | Path) -> McapRecorder:
        """Record every bus topic to an MCAP file (ROS 2 CDR, log time = sim time) until close()."""
        from racecar_sim.recording import McapRecorder  # mcap is imported only when a run records

        recorder = McapRecorder(path)
        self._recorders.append(recorder)
        self.bus.tap(lambda topic, msg: recorder.write(topic, msg, self.time_ns))
        for topic, msg in self.bus.latched_messages().items():
            recorder.write(topic, msg, self.time_ns)
        return recorder

    def close(self) -> None:
        """Finish every recording (writes the MCAP footers) and free the cameras' GL contexts."""
        for recorder in self._recorders:
            recorder.close()
        self._recorders.clear()
        for car in self.cars:
            car.close()

    def __enter__(self) -> Simulator:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # --- changing the model at run time (the Gazebo API's spawn and delete) -------------------------------
    def compile_spec(self) -> tuple[mujoco.MjModel, mujoco.MjData]:
        """Recompile `self.spec` after a change (a model spawned or deleted) into a new model and data that keep the
        state of everything that stays (MjSpec.recompile maps it by name); nothing is installed yet."""
        try:
            model, data = self.spec.recompile(self.model, self.data)
        except ValueError as exc:
            raise ConfigError(f"MuJoCo rejected the changed model: {exc}") from None
        try:
            if fit_near_walls(self.spec, model):  # a car or free body more: more near-wall slots
                model, data = self.spec.recompile(model, data)
        except ValueError as exc:
            raise ConfigError(f"MuJoCo rejected the changed model: {exc}") from None
        mujoco.mj_forward(model, data)
        return model, data

    def install_model(self, model: mujoco.MjModel, data: mujoco.MjData) -> None:
        """Go on with a recompiled model: every node is rebound (none is rebuilt), and reset() puts every model that
        is in it back at its initial pose."""
        self.model, self.data = model, data
        self._qpos0 = model.qpos0.copy()
        if self.near_walls is not None:
            self.near_walls.rebind(model, data)
            self.poses_changed()
        for car in self.cars:
            if car.state.model is not model:  # a car just spawned starts in the new model already
                car.rebind(model, data)
        roots = [car.state.body_id for car in self.cars]
        if len(self.cars) < 2:
            self._contacts = None
        elif self._contacts is None:
            self._contacts = CarContacts(model, roots)
        else:
            self._contacts.rebind(model, roots)
        self._touching = self._contacts.pairs(data) if self._contacts is not None else set()
        for hook in self._rebuild_hooks:
            hook(model, data)

    # --- internals --------------------------------------------------------------------------------
    def _publish_clock(self, now_ns: int) -> None:
        if not self._unheard_clock(now_ns):
            self.bus.publish(CLOCK, Clock(Time.from_ns(now_ns)))

    def _unheard_clock(self, _now_ns: int) -> bool:
        """A /clock message nobody would receive is counted, not built."""
        if self.bus.has_listeners(CLOCK):
            return False
        self.bus.tally(CLOCK, Clock)
        return True

    def _check_collisions(self) -> None:
        touching = self._contacts.pairs(self.data)
        for a, b in sorted(touching - self._touching):
            event = Collision(self.time_ns, (self.cars[a].model_name, self.cars[b].model_name))
            self.bus.publish(COLLISIONS, String(" ".join(event.cars)))
            for hook in self._collision_hooks:
                hook(event)
        self._touching = touching

    def _check_physics(self) -> None:
        """Stop at the first sign of divergence, before any node publishes the broken state.

        MuJoCo flags NaN or huge positions, velocities and accelerations in its warning counters; with its
        auto-reset off (physics.builder) the state stays as it diverged instead of silently jumping back.
        """
        counts = self.data.warning.number  # a view of the live counters: a cheap look, every event
        if not (counts[_DIVERGENCE_WARNINGS[0]] or counts[_DIVERGENCE_WARNINGS[1]] or counts[_DIVERGENCE_WARNINGS[2]]):
            return
        fired = [(kind, self.data.warning[kind].lastinfo) for kind in _DIVERGENCE_WARNINGS
                 if self.data.warning[kind].number]
        kind, index = fired[0]
        if kind == mujoco.mjtWarning.mjWARN_BADQPOS:  # a qpos index: the joint whose coordinates start at or before it
            jid = int((self.model.jnt_qposadr <= index).nonzero()[0][-1])
        else:  # a dof index
            jid = int(self.model.dof_jntid[min(index, self.model.nv - 1)])
        joint = mujoco.mj_id2name(self.model, mujoco.mjtObj.mjOBJ_JOINT, jid) or "root"
        self._divergence = (f"the physics diverged before t = {self.time:.3f} s (NaN or huge value at joint "
                            f"'{joint}'); the run stops. Check the controller gains in {self.cars[0].controllers_file}, the "
                            f"physics step ({self.model.opt.timestep:g} s) and the world's <physics> block")
        raise PhysicsError(self._divergence)


def _checked_fleet(cars: Sequence[Car]) -> list[Car]:
    cars = list(cars)
    if not cars:
        raise ConfigError("a Simulator needs at least one car")
    names = [car.model_name for car in cars]
    if len(set(names)) != len(names):
        raise ConfigError(f"car names must differ, got {', '.join(names)}")
    if any(car.spawn is None for car in cars[1:]):
        missing = [car.model_name for car in cars[1:] if car.spawn is None]
        raise ConfigError(f"only the first car takes the world's spawn pose: give {', '.join(missing)} a spawn")
    return cars


def _spawn_poses(sim: Simulator, spawn: Spawn | Mapping[str, Spawn] | Sequence[Spawn] | None) -> dict[int, Spawn]:
    """reset()'s spawn argument as {car index: pose}; ConfigError for an unknown car or a pose that is not a Spawn
    of finite numbers."""
    if spawn is None:
        return {}
    if isinstance(spawn, Spawn):
        poses = {0: spawn}
    elif isinstance(spawn, Mapping):
        poses = {}
        for name, pose in spawn.items():
            try:
                poses[sim.cars.index(sim.car_named(name))] = pose
            except KeyError as exc:
                raise ConfigError(f"reset spawn: {exc.args[0]}") from None
    elif isinstance(spawn, Sequence) and not isinstance(spawn, str):
        if len(spawn) > len(sim.cars):
            raise ConfigError(f"reset spawn: {len(spawn)} spawn poses for {len(sim.cars)} cars")
        poses = dict(enumerate(spawn))
    else:
        raise ConfigError(f"reset spawn={spawn!r}: give a Spawn, a Spawn per car, or a mapping of car names to Spawns")
    for index, pose in poses.items():
        who = f"reset spawn for {sim.cars[index].model_name}"
        if not isinstance(pose, Spawn):
            raise ConfigError(f"{who}: {pose!r} is not a Spawn(x, y, z, yaw)")
        for name in ("x", "y", "z", "yaw"):
            if not is_finite_number(getattr(pose, name)):
                raise ConfigError(f"{who}: {name} must be a finite number, got {getattr(pose, name)!r} ({pose})")
    return poses
