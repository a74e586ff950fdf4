"""A car: one vehicle's description, controllers, driving profile, sensors, spawn pose and namespace.

`Car(...)` is what a user asks for. The Simulator loads it (load: the xacro expanded, the profile and the controllers
read), puts it into the shared MjSpec (add_to: its bodies, and what each of its nodes needs in the model) and starts
its nodes on the shared bus (start). Which nodes a car runs:

  the command path    the ackermann_cmd_mux chain and servo_commands (what racecar.launch starts; `CarNodes`)
  model plugins       every <plugin> of the description the registry knows (runtime/plugins.py): gazebo_ros_control's
                      controllers, joint_state_controller and controller_manager; p3d; ...
  state publishers    robot_state_publisher and gazebo_odometry (racecar.launch; `CarNodes`)
  sensors             every <sensor> of the description: lasers, cameras, depth cameras, IMUs

Every node is built from one NodeContext (nodes/contract.py) and held in `car.nodes`, in that order; reset, rebind and
close loop over the list. All of a car's names come from its `CarNames`.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, TypeVar

import mujoco

from racecar_sim.control.controller_manager import JOINT_STATE_CONTROLLER, ControllerManager
from racecar_sim.control.mux import MUX_WIRING, CommandChain
from racecar_sim.control.profiles import Profile, load_profile
from racecar_sim.control.ros_control import RosControl
from racecar_sim.control.servo import ServoCommands
from racecar_sim.core.errors import ConfigError
from racecar_sim.core.names import ODOM_RELAY, CarNames
from racecar_sim.description import DEFAULT_XACRO, Robot, load_robot, package_path, parse_urdf
from racecar_sim.description.controllers import ControllerConfig, load_controller_config
from racecar_sim.description.vehicle_params import DEFAULT_VEHICLE, VehicleParams, load_vehicle
from racecar_sim.nodes import Mount, Node, NodeContext, Parts, ScopedBus, ScopedTimers, StaticTf, Timers
from racecar_sim.nodes.guard import GuardedNode
from racecar_sim.physics import PhysicsPreset, add_car
from racecar_sim.physics.actuation import limit_actuators
from racecar_sim.physics.builder import friction_min_rule
from racecar_sim.physics.state import CarState
from racecar_sim.physics.tyres import fill_tyre_table, open_differentials, prepare_tyres
from racecar_sim.runtime import plugins
from racecar_sim.sensors.odometry import FRAMES, OdometryPublisher
from racecar_sim.sensors.robot_state import RobotStatePublisher
from racecar_sim.worlds import Spawn

if TYPE_CHECKING:
    from racecar_sim.bus import BusPort
    from racecar_sim.sensors.camera import CameraPublisher
    from racecar_sim.sensors.lidar import LidarPublisher

_T = TypeVar("_T")
_N = TypeVar("_N", bound=Node)

DEFAULT_CONTROLLERS = package_path("racecar_control") / "config" / "racecar_control.yaml"


@dataclass(frozen=True)
class CarNodes:
    """Which nodes of the original stack's launch files a car runs; the defaults are racecar.launch's full set. A
    launch file that leaves one out leaves its work to someone else (a user's own ROS node through the bridge).

    mux: the ackermann_cmd_mux chain's wiring (control/mux.py: a YAML path or the same as a mapping), None for
        no muxes, relays or default command. servo_input: servo_commands' input topic (car-relative), "" for the
        chain's output, None for no servo_commands. controllers: those the spawner loads and starts (None: every
        controller of the YAML; joint_state_controller included), stopped: those it only loads (--stopped).
    robot_state: robot_state_publisher, reading `joint_states` (car-relative; None: <controller ns>/joint_states).
    odometry: gazebo_odometry.py; odom_relay: the topic_tools relay of /vesc/odom (None: no relay).
    """

    mux: Path | Mapping[str, Any] | None = MUX_WIRING
    servo_input: str | None = ""
    controllers: tuple[str, ...] | None = None
    stopped: tuple[str, ...] = ()
    robot_state: bool = True
    joint_states: str | None = None
    odometry: bool = True
    odom_relay: str | None = ODOM_RELAY


class Car:
    """One RACECAR (or a user's own car) in a Simulator.

    name: its namespace ("" keeps the original names: /scan, base_link, Gazebo model `racecar`; "car2" gives
    /car2/scan, car2/base_link, model `car2`). spawn: its pose (the first car defaults to the world's).
    lidar, camera: False turns off every sensor of that switch in the description (lasers; cameras and depth
    cameras); `sensors_off` names more switches ("imu"), kinds ("range"), sensor types or sensor names to leave out
    (runtime/plugins.py: `plugins.switches()`).
    nodes: which of the launch files' nodes it runs (`CarNodes`).
    vehicle: its tyre and actuator parameter set (description/vehicle_params.py): a shipped set's name (`seed`,
    `f1tenth`), a YAML file in F1TENTH's names, or a VehicleParams.
    """

    def __init__(
        self,
        name: str = "",
        xacro: str | Path = DEFAULT_XACRO,
        xacro_args: Mapping[str, str] | None = None,
        profile: str = "seed",
        controllers: str | Path | None = None,
        spawn: Spawn | None = None,
        lidar: bool = True,
        camera: bool = True,
        odometry: str = "original",
        nodes: CarNodes = CarNodes(),
        sensors_off: Iterable[str] = (),
        vehicle: str | Path | VehicleParams = DEFAULT_VEHICLE,
    ) -> None:
        self.names = CarNames(name)
        self.vehicle = load_vehicle(vehicle)
        self.name = name
        self.xacro = Path(xacro)
        self.xacro_args = dict(xacro_args or {})
        self.profile_name = profile
        self.controllers_file = Path(controllers or DEFAULT_CONTROLLERS)
        self.spawn = spawn
        self.off = frozenset(sensors_off) | {s for s, on in (("lidar", lidar), ("camera", camera)) if not on}
        if odometry not in FRAMES:
            raise ConfigError(f"odometry mode {odometry!r} is not one of {', '.join(FRAMES)}")
        self.odometry_mode = odometry
        self.plan = nodes
        self.urdf: str | None = None  # an expanded URDF to use instead of the xacro (spawn_urdf_model)
        self.nodes: list[Node] = []  # every node of the car, in the order it was built
        self.sensors: list[Node] = []  # the nodes of the description's <sensor> blocks, in its order
        self.chain: CommandChain | None = None
        self.servo: ServoCommands | None = None
        self.ros_control: RosControl | None = None
        self.robot_state: RobotStatePublisher | None = None
        self.odometry: OdometryPublisher | None = None
        self._profile: Profile | None = None
        self._robot: Robot | None = None
        self._controllers: ControllerConfig | None = None
        self._state: CarState | None = None
        self._context: NodeContext | None = None
        self._planned: tuple[list[plugins.Planned], list[plugins.Planned]] = ([], [])

    def __repr__(self) -> str:
        return f"Car({self.name or 'racecar'!r})"

    # --- what loading gives (an error before it, not None) ------------------------------------------------------
    @property
    def robot(self) -> Robot:
        """The parsed description (after the Simulator loaded the car)."""
        return _loaded(self._robot, self, "robot")

    @property
    def profile(self) -> Profile:
        """The driving profile."""
        return _loaded(self._profile, self, "profile")

    @property
    def controllers(self) -> ControllerConfig:
        """The controller configuration (racecar_control.yaml, checked against the description)."""
        return _loaded(self._controllers, self, "controllers")

    @property
    def state(self) -> CarState:
        """Access to the car's joints, actuators and base in the MuJoCo data (once started)."""
        return _loaded(self._state, self, "state")

    @property
    def model_name(self) -> str:
        """Its Gazebo model name (`racecar` for the unnamed car, else its namespace)."""
        return self.names.model

    # --- the nodes, by what they are --------------------------------------------------------------------------
    @property
    def lidar(self) -> LidarPublisher | None:
        """The car's first laser (None when it has none, or it is off)."""
        from racecar_sim.sensors.lidar import LidarPublisher

        return next((n for n in self.sensors if isinstance(n, LidarPublisher)), None)

    @property
    def camera(self) -> CameraPublisher | None:
        """The car's first camera (None when it has none, it is off, or no OpenGL context could be made)."""
        if not self.has("camera"):
            return None
        from racecar_sim.sensors.camera import CameraPublisher

        return next((n for n in self.sensors if isinstance(n, CameraPublisher)), None)

    def has(self, kind: str) -> bool:
        """Whether the car has a sensor of the kind named `kind` (runtime/plugins.py: "laser", "range", "camera",
        "depth_camera", "imu", ...) that is on."""
        return any(p.kind.name == kind for p in self._planned[1])

    def sensor_specs(self, kind: str) -> list[Any]:
        """The parsed blocks of the car's sensors of the kind named `kind` that are on."""
        return [p.spec for p in self._planned[1] if p.kind.name == kind]

    @property
    def has_lidar(self) -> bool:
        """Whether the car has a laser that is on."""
        return self.has("laser")

    @property
    def has_camera(self) -> bool:
        """Whether the car has a camera that is on."""
        return self.has("camera")

    @property
    def commands(self) -> Any:
        """The controllers' command node (ControllerCommands)."""
        return _loaded(self.ros_control, self, "controllers").commands

    @property
    def controller_manager(self) -> ControllerManager:
        """The car's controller_manager."""
        return _loaded(self.ros_control, self, "controllers").manager

    @property
    def joint_states(self) -> Any:
        """The car's joint_state_controller (JointStatePublisher)."""
        return _loaded(self.ros_control, self, "controllers").joint_states

    # --- the lifecycle ----------------------------------------------------------------------------------------
    def load(self, twin: Car | None = None) -> None:
        """Read the profile, expand the xacro and check the controllers against it; or, when `twin` (loaded already)
        asked for the same description, profile and controllers, share what it read (a fleet of N identical cars
        expands the xacro once: ~0.1 s a car otherwise; the parsed description and configuration are immutable)."""
        if twin is not None and twin._robot is not None and self._load_key() == twin._load_key():
            self._profile, self._robot, self._controllers = twin._profile, twin._robot, twin._controllers
        else:
            self._profile = profile = load_profile(self.profile_name)
            if self.urdf is not None:  # already expanded: the profile's xacro arguments cannot apply any more
                self._robot = parse_urdf(self.urdf, source=f"the URDF of {self.model_name}")
            else:
                self._robot = load_robot(self.xacro, {**profile.xacro_args, **self.xacro_args})
            self._controllers = load_controller_config(self.controllers_file, self._robot)
        self._planned = plugins.plan(self.robot, self.off, Mount(self.robot, self.names, self.controllers))

    def _load_key(self) -> tuple[object, ...]:
        return (self.profile_name, self.xacro, tuple(sorted(self.xacro_args.items())), self.controllers_file, self.urdf)

    def add_to(self, spec: mujoco.MjSpec, preset: PhysicsPreset, spawn: Spawn, rank_friction: bool = True) -> None:
        """Put the car into the scene's MjSpec at `spawn`, with what each of its nodes needs in the model (actuators,
        cameras, sensor sites); rank_friction=False leaves builder.friction_min_rule to the caller (once, after the
        last car of a fleet)."""
        add_car(spec, self.robot, spawn, preset, self.names, rank_friction=False)
        prepare_tyres(spec, self.robot, self.names, self.vehicle)
        if rank_friction:
            friction_min_rule(spec)
        mount = Mount(self.robot, self.names, self.controllers)
        for planned in (*self._planned[0], *self._planned[1]):
            if planned.kind.prepare is not None:
                planned.kind.prepare(spec, planned.spec, mount)
        open_differentials(spec, self.robot, self.names, self.vehicle)
        limit_actuators(spec, self.robot, self.names, self.vehicle)

    def start(
        self,
        model: mujoco.MjModel,
        data: mujoco.MjData,
        bus: BusPort,
        timers: Timers,
        now: Callable[[], int],
        static_tf: StaticTf,
        seed: int,
        noise: bool,
    ) -> None:
        """Start the car's nodes on the bus. Called once: they live as long as the Simulator (or until stop(): the car
        was deleted). Their timers start now (a car spawned at t = 2 s scans at 2.025 s..., as a Gazebo sensor counts
        from its load), and everything they hold on the bus is kept for stop()."""
        self._state = state = CarState(model, data, self.robot.root, self.names)
        fill_tyre_table(model, self.robot, self.names, self.vehicle)
        ctx = self._context = NodeContext(
            ScopedBus(bus),
            ScopedTimers(timers, now()),
            model,
            data,
            self.names,
            seed,
            now,
            noise,
            self.robot,
            state,
            self.controllers,
            static_tf,
        )
        plan, names = self.plan, self.names
        if plan.mux is not None:
            self.chain = self.hold(CommandChain(ctx.bus, ctx.timers, now, plan.mux, names=names))
        if plan.servo_input is not None:
            servo_input = names.topic(plan.servo_input) if plan.servo_input else self._chain_output()
            self.servo = self.hold(
                ServoCommands(
                    ctx.bus,
                    self.robot,
                    self.controllers,
                    self.profile.servo,
                    servo_input,
                    self.profile.wheel_rate_per_speed,
                    now,
                    names,
                    self.vehicle,
                )
            )
        model_plugins, sensors = self._planned
        self._bind_parts(model)
        for planned in model_plugins:
            ctx.parts = planned.parts
            node = planned.kind.build(ctx, planned.spec)
            if node is None:  # it cannot run here, and has said why
                continue
            self.hold(node)
            if isinstance(node, RosControl):
                self.ros_control = node
        self._spawn_controllers()
        if plan.robot_state:
            joint_states = names.topic(f"{self.controllers.namespace}/joint_states")
            rsp_input = names.topic(plan.joint_states) if plan.joint_states else joint_states
            self.robot_state = self.hold(RobotStatePublisher(ctx.bus, self.robot, rsp_input, names, static_tf))
        if plan.odometry:
            self.odometry = self.hold(
                OdometryPublisher(
                    ctx.bus, ctx.timers, state, self.odometry_mode, relay_topic=plan.odom_relay, names=names
                )
            )
        kept = []
        for planned in sensors:
            ctx.parts = planned.parts
            node = planned.kind.build(ctx, planned.spec)
            if node is not None:  # a camera without OpenGL has said so, and is left out
                self.sensors.append(self.hold(node))
                kept.append(planned)
        self._planned = (model_plugins, kept)
        ctx.parts = Parts()

    def _bind_parts(self, model: mujoco.MjModel) -> None:
        """Bind every planned node's MuJoCo parts to a compiled model (nodes/parts.py)."""
        for planned in (*self._planned[0], *self._planned[1]):
            planned.parts.bind(model)

    def add_node(self, factory: Callable[..., Node], **params: Any) -> Node:
        """Build a node of the car from its context (`factory(ctx, **params)`, e.g. a user's driver class) and hold it
        with the car's own: its reset, rebind and close hooks run with theirs. What the node raises, built or called
        (a subscription, a timer, a hook), stops the run as a NodeError naming it, the car and the sim time
        (nodes/guard.py)."""
        return self.hold(GuardedNode(factory, self.context, self.model_name, **params)).node

    @property
    def context(self) -> NodeContext:
        """The context the car's nodes are built from (once started)."""
        return _loaded(self._context, self, "nodes")

    def hold(self, node: _N) -> _N:
        """Hold a node built elsewhere (a driver attached to the car) with the car's own: its hooks run with theirs."""
        self.nodes.append(node)
        return node

    def _chain_output(self) -> str:
        if self.chain is None:
            raise ConfigError(
                f"{self.model_name}: servo_commands reads the mux chain's output, but the car has no "
                "mux chain: give CarNodes(servo_input=TOPIC)"
            )
        return self.chain.output_topic

    def _spawn_controllers(self) -> None:
        """What the spawner leaves: the controllers it names loaded (and started unless --stopped), no others."""
        wanted, stopped = self.plan.controllers, set(self.plan.stopped)
        if self.ros_control is None or (wanted is None and not stopped):
            return
        defined = [c.name for c in self.controllers.controllers] + [JOINT_STATE_CONTROLLER]
        keep = stopped | set(defined if wanted is None else wanted)
        unknown = sorted(keep - set(defined))
        if unknown:
            raise ConfigError(
                f"{self.model_name}: controller {', '.join(unknown)} is not in the controller parameters "
                f"(namespace {self.controllers.namespace}): load its parameters (rosparam) or drop it"
            )
        manager = self.ros_control.manager
        manager.switch_controller([], [c for c in defined if c not in keep or c in stopped])
        for name in [c for c in defined if c not in keep]:
            manager.unload_controller(name)

    def reset(self, seed: int) -> None:
        """Back to a fresh start: every node's reset hook (muxes idle, controllers as the spawner leaves them, sensors'
        noise from `seed`)."""
        if self._context is not None:
            self._context.seed = seed
        for node in self.nodes:
            node.reset(seed)
        self._spawn_controllers()

    def rebind(self, model: mujoco.MjModel, data: mujoco.MjData) -> None:
        """Go on in a recompiled model (a model was spawned or deleted): the same nodes, new ids and addresses."""
        self.state.rebind(model, data)
        fill_tyre_table(model, self.robot, self.names, self.vehicle)
        if self._context is not None:
            self._context.model, self._context.data = model, data
        self._bind_parts(model)  # before the nodes' hooks: they read their parts' new ids
        for node in self.nodes:
            node.rebind(model, data)

    def close(self) -> None:
        """Every node's close hook, last built first (frees the cameras' GL objects)."""
        for node in reversed(self.nodes):
            node.close()

    def stop(self) -> None:
        """Take the car's nodes off the bus (delete_model): cancel their timers, drop their subscriptions and
        services, close the nodes."""
        if self._context is not None:
            assert isinstance(self._context.timers, ScopedTimers) and isinstance(self._context.bus, ScopedBus)
            self._context.timers.cancel_all()
            self._context.bus.release()
        self.close()

    def remove_from(self, spec: mujoco.MjSpec) -> None:
        """Delete the car from the scene's MjSpec: its bodies (with their geoms, joints, sites and cameras), the
        actuators on its joints, the sensors on its sites and its contact exclusions."""
        root = spec.body(self.names.mj(self.robot.root))
        if root is None:
            return
        bodies = {root.name} | {b.name for b in root.find_all(mujoco.mjtObj.mjOBJ_BODY)}
        joints = {j.name for j in root.find_all(mujoco.mjtObj.mjOBJ_JOINT)}
        sites = {s.name for s in root.find_all(mujoco.mjtObj.mjOBJ_SITE)}
        for actuator in [a for a in spec.actuators if a.target in joints]:
            spec.delete(actuator)
        for sensor in [s for s in spec.sensors if s.objname in sites]:
            spec.delete(sensor)
        for exclude in [e for e in spec.excludes if e.bodyname1 in bodies or e.bodyname2 in bodies]:
            spec.delete(exclude)
        spec.delete(root)

    def topic(self, name: str) -> str:
        """One of this car's topics by its original name: car.topic("/scan") -> "/car2/scan"."""
        return self.names.topic(name)


def _loaded(value: _T | None, car: Car, what: str) -> _T:
    if value is None:
        raise RuntimeError(f"{car!r} has no {what} yet: put it in a Simulator (which loads and starts it)")
    return value
