"""The Simulator: a world, its cars, the nodes of the original stack on one bus, and a sim clock.

It composes the parts and owns none of their work: the scene (physics/scene.py: the MjSpec, the compiled model and
data, the map walls near the cars), the event loop (event_loop.py: stepping between events, pause, defer,
divergence), the cars (car.py: each with its nodes) and the world's own nodes - /clock, /tf_static, the collision
watch and Gazebo's ROS API (gazebo_api.py, which changes the scene only through spawn_car, delete_car and
add/remove_world_bodies here). The bus, the scheduler, the model and every node live as long as the Simulator:
reset() restores the physics and calls every node's reset hook, it rebuilds nothing.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import mujoco

from racecar_sim.bus import Bus, Subscription
from racecar_sim.core.errors import ConfigError
from racecar_sim.core.rng import check_seed
from racecar_sim.core.throttle import is_finite_number
from racecar_sim.core.time import NS_PER_S, to_ns
from racecar_sim.description import DEFAULT_XACRO
from racecar_sim.description.vehicle import VehicleGeometry
from racecar_sim.description.vehicle_params import DEFAULT_VEHICLE, VehicleParams
from racecar_sim.nodes import Node
from racecar_sim.physics import check_spawn, load_preset, route_mujoco_warnings
from racecar_sim.physics.scene import Scene
from racecar_sim.render.gl import start_shared_context
from racecar_sim.runtime.car import Car
from racecar_sim.runtime.clock import CLOCK_RATE, ClockPublisher
from racecar_sim.runtime.collisions import COLLISIONS, Collision, Crash, Crashes, WatchedCar
from racecar_sim.runtime.compiled import load_numba
from racecar_sim.runtime.event_loop import EventLoop
from racecar_sim.runtime.fleet import car_index, checked_fleet, spawn_poses
from racecar_sim.runtime.gazebo_api import GazeboApi
from racecar_sim.runtime.laps import Laps
from racecar_sim.runtime.scheduler import Scheduler
from racecar_sim.sensors.robot_state import StaticTransforms
from racecar_sim.worlds import DEFAULT_WALL_HEIGHT, Spawn, World, load_world
from racecar_sim.worlds.start_line import StartLine, start_line_of
from racecar_sim.worlds.world import WorldBody

if TYPE_CHECKING:
    import numpy as np

    from racecar_sim.recording import McapRecorder

__all__ = ["CLOCK_RATE", "COLLISIONS", "Collision", "Crash", "Simulator"]


class Simulator:
    """RACECARs in one world: one car with the original names by default, or a fleet given as `cars`.

    >>> sim = Simulator(world="empty", profile="seed", seed=0)
    >>> sim.publish("/vesc/ackermann_cmd_mux/input/navigation", AckermannDriveStamped(drive=AckermannDrive(speed=1.0)))
    >>> sim.run_until(2.0)

    >>> fleet = Simulator(world="tunnel", cars=[Car("car1"), Car("car2", spawn=Spawn(-1.5, 0, 0.05, 0))])

    Every topic of the original is on `sim.bus` under its original name, each car's under its namespace; Gazebo's
    own (/gazebo/model_states, /gazebo/link_states and the /gazebo/* services: get/set_model_state, spawn_urdf_model,
    spawn_sdf_model, delete_model, pause/unpause_physics, reset_simulation/reset_world) come from `sim.gazebo`.
    `sim.car` is the first (or only) car: its nodes (`sim.car.lidar`, `sim.car.state`, ...) are there.
    Same world, cars, seed and inputs give bit-identical messages.

    `lidar`, `camera` (False: every laser, every camera and depth camera of the description left out) and
    `sensors_off` (more switches, "imu", sensor types or sensor names) choose the sensors (runtime/plugins.py).

    `start_line` (x1, y1, x2, y2 in m): where laps are counted (default: the world's own, worlds/start_line.py); the
    laps are in `sim.laps` (None for a world with neither a start line nor a centerline).

    `near_walls` (default on): a world body of many wall boxes (a map) is held out of MuJoCo's collision model and
    only the boxes within reach of each car or free body are placed in it (physics.near_walls; the same contacts
    at a fraction of the cost); off, every box is a geom.
    """

    def __init__(
        self,
        world: str | World = "empty",
        profile: str = "seed",
        seed: int = 0,
        physics: str = "default",
        spawn: Spawn | None = None,
        odometry: str = "original",
        xacro: str | Path = DEFAULT_XACRO,
        xacro_args: Mapping[str, str] | None = None,
        controllers: str | Path | None = None,
        model_path: list[str | Path] | None = None,
        wall_height: float = DEFAULT_WALL_HEIGHT,
        lidar: bool = True,
        camera: bool = True,
        sensor_noise: bool = True,
        cars: Sequence[Car] | None = None,
        near_walls: bool = True,
        sensors_off: Sequence[str] = (),
        start_line: Sequence[float] | None = None,
        vehicle: str | Path | VehicleParams = DEFAULT_VEHICLE,
    ) -> None:
        self.seed = check_seed(seed)
        self.sensor_noise = sensor_noise
        if cars is None:
            cars = [
                Car(
                    "",
                    xacro,
                    xacro_args,
                    profile,
                    controllers,
                    spawn,
                    lidar,
                    camera,
                    odometry,
                    sensors_off=sensors_off,
                    vehicle=vehicle,
                )
            ]
        else:
            given = [
                name
                for name, value, default in (
                    ("profile", profile, "seed"),
                    ("spawn", spawn, None),
                    ("odometry", odometry, "original"),
                    ("xacro", xacro, DEFAULT_XACRO),
                    ("xacro_args", xacro_args, None),
                    ("controllers", controllers, None),
                    ("lidar", lidar, True),
                    ("camera", camera, True),
                    ("sensors_off", tuple(sensors_off), ()),
                    ("vehicle", vehicle, DEFAULT_VEHICLE),
                )
                if value != default
            ]
            if given:
                raise ConfigError(f"with cars=[...], give {', '.join(given)} to each Car, not to the Simulator")
        self.cars = checked_fleet(cars)
        for index, car in enumerate(self.cars):
            car.load(self.cars[index - 1] if index else None)  # a fleet of identical cars expands the xacro once
        self._start_gl()
        first = self.cars[0]
        self.world = (
            world
            if isinstance(world, World)
            else load_world(world, first.spawn, [Path(p) for p in model_path or []], wall_height)
        )
        if first.spawn is not None:
            self.world.spawn = first.spawn
        self.spawns = [car.spawn or self.world.spawn for car in self.cars]
        self.preset = load_preset(physics)
        route_mujoco_warnings()
        self.scene = Scene(
            self.world, self.preset, near_walls, first.robot.name if len(self.cars) == 1 else self.world.name or "fleet"
        )
        for car, car_spawn in zip(self.cars, self.spawns):
            car.add_to(self.scene.spec, self.preset, car_spawn, rank_friction=False)
        self.scene.compile(blame=first.xacro)
        for car, car_spawn in zip(self.cars, self.spawns):  # WorldError: inside an obstacle or a car, no ground
            check_spawn(self.model, self.data, self.world, car.robot, car.names, car_spawn)
        self.loop = EventLoop(self.scene, self._divergence_advice)
        self.bus = Bus()
        self.scheduler: Scheduler = self.loop.scheduler
        self._recorders: list[McapRecorder] = []
        self._reset_hooks: list[Callable[[], None]] = []
        self._rebuild_hooks: list[Callable[[mujoco.MjModel, mujoco.MjData], None]] = []
        # the world's nodes
        self._near_walls_look = self.scheduler.timeout(lambda _now: self.poses_changed(), "near_walls")
        self.poses_changed()
        self.static_tf = StaticTransforms(self.bus)
        self.clock = ClockPublisher(self.bus, self.scheduler)
        self._start_cars()
        self.collisions = Crashes(self.bus, lambda: self.loop.time_ns)
        self._watch_collisions(known=False)
        self.gazebo = GazeboApi(self)  # /gazebo/link_states, /gazebo/model_states and the /gazebo/* services
        self.world_nodes: list[Node] = [self.clock, self.collisions, self.gazebo]
        self.laps = self._lap_counter(start_line)
        if self.laps is not None:
            self.world_nodes.append(self.laps)
        self._load_compiled()

    def _start_gl(self) -> None:
        """Begin the cameras' headless GL context now, on its own thread, at the first camera's image size (the size
        it would ask for): the driver's loading and EGL's set-up overlap the world's build and numba's load."""
        sizes = [(spec.width, spec.height) for car in self.cars for spec in car.sensor_specs("camera")]
        if sizes:
            start_shared_context(*sizes[0])

    def _start_cars(self) -> None:
        """Start every car's nodes. With cameras, their MjrContext is begun first on the GL thread (llvmpipe's first
        upload, 0.2-0.3 s without the GIL) and numba is loaded meanwhile, before the cameras load their frame
        finishing (numba) as they start."""
        if not any(car.has_camera for car in self.cars):
            for car in self.cars:
                self._start_car(car)
            return
        from racecar_sim.render.offscreen import drop_unclaimed_context, prepare_context

        prepare_context(self.model)
        try:
            load_numba()
            for car in self.cars:
                self._start_car(car)
        finally:
            drop_unclaimed_context(self.model)  # a camera that failed to start

    def _load_compiled(self) -> None:
        """numba, and the compiled scan of a world with walls, loaded by the build: a one-time cost of the start, not
        of the first scan inside the run (cameras load their kernels as they start)."""
        lidars = [car.lidar for car in self.cars if car.lidar is not None and car.lidar.caster.compiled]
        if lidars:
            load_numba()
            lidars[0].warm()  # the kernels load once a process: one lidar loads them for the fleet

    # --- the parts, under the names the API always had -----------------------------------------------------
    @property
    def car(self) -> Car:
        """The first car (the only one unless `cars` was given)."""
        return self.cars[0]

    model = property(
        lambda self: self.scene.model,
        doc="The compiled MuJoCo model (replaced when models are spawned or deleted at run time).",
    )
    data = property(lambda self: self.scene.data, doc="The MuJoCo data: the state of the simulation.")
    spec = property(lambda self: self.scene.spec, doc="The scene's MjSpec (physics/scene.py).")
    near_walls = property(lambda self: self.scene.near_walls, doc="The map walls held near the cars, or None.")
    step_ns = property(lambda self: self.loop.step_ns, doc="The physics step in ns.")

    @property
    def time_ns(self) -> int:
        """Sim time in ns."""
        return self.loop.time_ns

    @property
    def time(self) -> float:
        """Sim time in seconds."""
        return self.loop.time_ns / NS_PER_S

    @property
    def paused(self) -> bool:
        """Whether the physics is paused (/gazebo/pause_physics): sim time stands still until unpaused."""
        return self.loop.paused

    @paused.setter
    def paused(self, value: bool) -> None:
        self.loop.paused = value

    def car_named(self, name: str) -> Car:
        """A car by its namespace (or its Gazebo model name: `racecar` for the unnamed car)."""
        return self.cars[car_index(self.cars, name)]

    # --- the public API -------------------------------------------------------------------------------------
    def publish(self, topic: str, msg: Any) -> None:
        """Publish on the bus now (at the current sim time)."""
        self.bus.publish(topic, msg)

    def subscribe(self, topic: str, callback: Callable[[Any], None], msgtype: type | None = None) -> Subscription:
        """Call `callback(msg)` for every message on `topic` (the bus lives as long as the Simulator).

        `msgtype` declares the message class taken, so that a ROS bridge subscribes to the topic on the ROS side.
        """
        return self.bus.subscribe(topic, callback, msgtype)

    def add_node(self, factory: Callable[..., Node], car: Car | str | None = None, **params: Any) -> Node:
        """Build a node of a car from the car's context - `factory(ctx, **params)`, e.g. a driver class written to the
        node contract (racecar_sim.nodes) - and hold it with the car's own nodes: its reset, rebind and close hooks
        run with theirs. `car`: a Car, a car's name, or None for the first car."""
        owner = car if isinstance(car, Car) else self.car if car is None else self.car_named(car)
        return owner.add_node(factory, **params)

    def on_reset(self, hook: Callable[[], None]) -> None:
        """Call `hook()` after every reset(), once the physics is back at its start (a driver clears its state)."""
        self._reset_hooks.append(hook)

    def on_collision(self, hook: Callable[[Collision], None]) -> None:
        """Call `hook(Collision)` when two cars start touching (checked at every event, not every physics step)."""
        self.collisions.hooks.append(hook)

    def on_rebuild(self, hook: Callable[[mujoco.MjModel, mujoco.MjData], None]) -> None:
        """Call `hook(model, data)` when a model spawned or deleted at run time replaced `sim.model` and `sim.data`
        (the Simulator's own nodes are rebound already; a user's node holding the old ones should take these)."""
        self._rebuild_hooks.append(hook)

    def poses_changed(self) -> None:
        """Models were moved by hand (a reset, a teleport; mj_forward done): bring up to date what depends on where
        they are: the map walls within reach of each car (physics.near_walls, which also says when to look again)."""
        look = self.scene.refresh_near_walls()
        if look is not None:
            self._near_walls_look.restart(self.loop.time_ns + to_ns(look))

    def defer(self, action: Callable[[], None]) -> None:
        """Run `action()` once the event being handled is over (at once outside of run_until): what moves sim
        time (reset) must not happen while the scheduler is firing the tasks due now."""
        self.loop.defer(action)

    def run_until(self, t: float) -> None:
        """Advance sim time to `t` seconds (rounded up to a physics step), firing every event on the way.

        While the physics is paused (/gazebo/pause_physics) sim time stands still, as in a paused Gazebo: nothing
        steps, no timer fires, nothing publishes, and run_until returns at once (logging it once per pause); a loop
        that waits for sim time must call /gazebo/unpause_physics. A pause asked for during an event stops the run
        after that event.
        """
        self.loop.run_until(t)

    def run_for(self, duration: float) -> None:
        """Advance sim time by `duration` seconds."""
        self.run_until(self.time + duration)

    def reset(
        self, seed: int | None = None, spawn: Spawn | Mapping[str, Spawn] | Sequence[Spawn] | None = None
    ) -> None:
        """Back to t = 0 with every car at its spawn pose (or at `spawn`: one pose for the first car, a pose per
        car in order, or a mapping of car names to poses), and a new noise `seed` if given.

        Nothing is rebuilt: subscriptions, timers, recorders, bridges and every node stay attached; each node's reset
        hook runs (muxes idle, sensors take the seed), then the hooks given to on_reset(). Asked for from inside an
        event (a callback or a timer), the reset happens once that event is over, and a run_until in progress then
        goes on on the new clock, to its target time.

        A pose given is checked as the constructor checks spawns (a WorldError if the car would be inside an
        obstacle or another car, or have no ground under it; a ConfigError for a pose that is not finite numbers);
        refused, the reset does not happen: the sim is left as it was.
        """
        new_seed = self.seed if seed is None else check_seed(seed)
        poses = spawn_poses(self.cars, spawn)  # a malformed pose is refused at once, even from inside an event
        if self.loop.in_event:
            self.defer(lambda: self.reset(seed, spawn))
            return
        saved = self._backup() if poses else None  # to put back if a pose is refused
        self.car.state.reset(self.scene.qpos0)
        for index, pose in poses.items():
            self.cars[index].state.set_base_pose(pose.x, pose.y, pose.z, pose.yaw)
        mujoco.mj_forward(self.model, self.data)
        if saved is not None:
            self._check_spawns(poses, saved)
        self.seed = new_seed
        self.loop.restart()
        self.poses_changed()
        for node in self.world_nodes:
            node.reset(self.seed)
        for car in self.cars:
            car.reset(self.seed)
        for hook in self._reset_hooks:
            hook()

    def record(self, path: str | Path) -> McapRecorder:
        """Record every bus topic to an MCAP file (ROS 2 CDR, log time = sim time) until close()."""
        from racecar_sim.recording import McapRecorder  # mcap is imported only when a run records

        recorder = McapRecorder(path)
        self._recorders.append(recorder)
        self.bus.tap(lambda topic, msg: recorder.write(topic, msg, self.loop.time_ns))
        for topic, msg in self.bus.latched_messages().items():
            recorder.write(topic, msg, self.loop.time_ns)
        return recorder

    def close(self) -> None:
        """Finish every recording (writes the MCAP footers), then every node's close hook (the cameras' GL objects)."""
        for recorder in self._recorders:
            recorder.close()
        self._recorders.clear()
        for car in self.cars:
            car.close()
        for node in self.world_nodes:
            node.close()

    def __enter__(self) -> Simulator:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # --- changing the scene at run time: what the Gazebo API's spawn and delete call --------------------------
    def spawn_car(self, car: Car, quat: Sequence[float] | np.ndarray | None = None) -> None:
        """Add a loaded car to the running simulation at its spawn pose (turned by `quat`, w x y z, if given): into the
        scene, checked like a start-up spawn, its nodes started now. RacecarSimError (and nothing changed) if it
        cannot be."""
        spec = self.scene.spec
        try:
            car.add_to(spec, self.preset, car.spawn or self.world.spawn)
            if quat is not None:
                spec.body(car.names.mj(car.robot.root)).quat = list(quat)  # the full orientation
            model, data = self.scene.recompile()
            check_spawn(model, data, self.world, car.robot, car.names, car.spawn or self.world.spawn)
        except Exception:
            car.remove_from(spec)
            raise
        self._start_car(car, model, data)
        self.cars.append(car)
        self._install(model, data)

    def delete_car(self, car: Car) -> None:
        """Take a car out of the running simulation: its nodes off the bus, its bodies out of the scene."""
        car.stop()
        car.remove_from(self.scene.spec)
        self.cars.remove(car)
        self._install(*self.scene.recompile())

    def add_world_bodies(self, bodies: list[WorldBody], prefix: str) -> None:
        """Add world objects (a spawned SDF model's links) to the running simulation; RacecarSimError (and nothing
        changed) if MuJoCo cannot take them."""
        self.scene.attach_bodies(bodies, prefix)
        try:
            model, data = self.scene.recompile()
        except Exception:
            self.scene.remove_bodies(bodies)
            raise
        self.world.bodies.extend(bodies)
        self._install(model, data)

    def remove_world_bodies(self, bodies: list[WorldBody]) -> None:
        """Take world objects (a model's links) out of the running simulation."""
        self.scene.remove_bodies(bodies)
        self.world.bodies = [b for b in self.world.bodies if all(b is not own for own in bodies)]
        self._install(*self.scene.recompile())

    # --- internals --------------------------------------------------------------------------------------------
    def _start_car(self, car: Car, model: mujoco.MjModel | None = None, data: mujoco.MjData | None = None) -> None:
        """The one place a car's nodes start: at start-up, and when a car is spawned at run time."""
        car.start(
            model or self.model,
            data or self.data,
            self.bus,
            self.scheduler,
            lambda: self.loop.time_ns,
            self.static_tf,
            self.seed,
            self.sensor_noise,
        )

    def _install(self, model: mujoco.MjModel, data: mujoco.MjData) -> None:
        """Go on with a recompiled model: every node is rebound (none is rebuilt)."""
        self.scene.install(model, data)
        self.poses_changed()
        for car in self.cars:
            if car.state.model is not model:  # a car just spawned starts in the new model already
                car.rebind(model, data)
        for node in self.world_nodes:
            node.rebind(model, data)
        self._watch_collisions(known=True)
        if self.laps is not None:
            self._watch_laps(self.laps)
        for hook in self._rebuild_hooks:
            hook(model, data)

    def _lap_counter(self, given: Sequence[float] | None) -> Laps | None:
        """The lap counter on the world's start line (or `given`: x1, y1, x2, y2), None for a world without one."""
        if given is not None:
            if len(given) != 4 or not all(is_finite_number(v) for v in given):
                raise ConfigError(f"start line {tuple(given)!r}: give four finite numbers x1, y1, x2, y2 (m)")
            x1, y1, x2, y2 = (float(v) for v in given)
            try:
                line: StartLine | None = StartLine.through(x1, y1, x2, y2, self.world.spawn.yaw)
            except ValueError:
                raise ConfigError(f"start line {tuple(given)!r}: its two ends are the same point") from None
        else:
            line = start_line_of(self.world)
        if line is None:
            return None
        centerline = self.world.centerline
        laps = Laps(self.bus, self.scheduler, line, centerline.length if centerline is not None else None)
        self._watch_laps(laps)
        return laps

    def _watch_laps(self, laps: Laps) -> None:
        def pose_of(car: Car) -> Callable[[], tuple[float, float]]:
            def pose() -> tuple[float, float]:
                position, _ = car.state.base_pose()
                return float(position[0]), float(position[1])

            return pose

        laps.watch([(car.model_name, pose_of(car)) for car in self.cars])

    def _watch_collisions(self, known: bool) -> None:
        model = self.model
        watched = [
            WatchedCar(
                car.model_name,
                car.state.body_id,
                tuple(model.body(car.names.mj(w.link)).id for w in VehicleGeometry.from_robot(car.robot).wheels),
            )
            for car in self.cars
        ]
        self.collisions.watch(model, self.data, watched, known)
        self.loop.after_physics = self.collisions.check
        self.loop.stop_at_every_task = len(self.cars) > 1  # a fleet's contacts at every task, as its nodes run

    def _divergence_advice(self) -> str:
        return (
            f"Check the controller gains in {self.car.controllers_file}, the physics step "
            f"({self.model.opt.timestep:g} s) and the world's <physics> block"
        )

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
            self.scene.refresh_near_walls()
            for index, pose in poses.items():
                car = self.cars[index]
                check_spawn(self.model, self.data, self.world, car.robot, car.names, pose)
        except Exception:
            mujoco.mj_copyData(self.data, self.model, saved)
            self.scene.refresh_near_walls()
            raise
