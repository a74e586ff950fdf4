"""A LaunchPlan onto the sim: the original stack's nodes become each car's own nodes (runtime/car.py CarNodes).

A node belongs to the car whose namespace holds it (a spawn_model in `<group ns="car1">` makes car1; the root
namespace's spawn the unnamed car, model `racecar`). Topic names a node resolves outside its car's namespace
(the original's absolute /vesc/... in a fleet group) are taken as that car's own. A sim node exists only if the
launch asks for it; nodes the sim has no equivalent for are started through the ROS bridge with `--ros`, and
otherwise skipped with a warning (or an error, for a node marked required="true").

The joystick of racecar-v2-teleop.launch.xml (`joy/joy_node` and `racecar/joy_teleop.py`, in `<group ns="vesc">`)
becomes control/joy.py's JoyNode, reading a gamepad, and control/joy_teleop.py's JoyTeleop, with the parameters the
launch gives them (joy_node's `~deadzone`..., joy_teleop's `teleop` in its namespace). Without a gamepad the
JoyNode is left out with a warning, and JoyTeleop still takes sensor_msgs/Joy on the bus (and from ROS with --ros).
"""

from __future__ import annotations

import logging
import tempfile
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from typing import Any

import yaml

from racecar_sim.control.joy import JoyNode, JoyNodeConfig
from racecar_sim.control.joy_teleop import JoyCommand, JoyTeleop, parse_commands
from racecar_sim.control.mux import load_mux_inputs
from racecar_sim.core.errors import ConfigError
from racecar_sim.core.names import NAVIGATION, ODOM, TELEOP, CarNames
from racecar_sim.description.vehicle_params import DEFAULT_VEHICLE, VehicleParams
from racecar_sim.launch.errors import LaunchError
from racecar_sim.launch.plan import LaunchPlan, NodeSpec
from racecar_sim.launch.rosnames import SEP, canonical, global_ns, strip_ns
from racecar_sim.launch.spawn import (
    SERVERS,
    CarSpawn,
    WorldChoice,
    parse_spawn,
    world_of,
)
from racecar_sim.runtime import Simulator
from racecar_sim.runtime.car import DEFAULT_CONTROLLERS, Car, CarNodes

log = logging.getLogger("racecar_sim.launch")
SERVO_INPUT = "/racecar/ackermann_cmd_mux/output"  # servo_commands.py's own subscription, before remapping
MUX_NODELET = "ackermann_cmd_mux/AckermannCmdMuxNodelet"
ACKERMANN = "ackermann_msgs/AckermannDriveStamped"
DRIVERS = ("wall_follow", "pure_pursuit", "constant")
NO_OP = {("gazebo_ros", "gzclient"): "the sim draws no Gazebo GUI (see `racecar-sim live`)"}
JOY_NODE = ("joy", "joy_node")
JOY_TELEOP = (("racecar", "joy_teleop.py"), ("joy_teleop", "joy_teleop.py"))


@dataclass
class DriverSpec:
    """A `pkg="racecar_sim"` driver node: its kind, car, private params and the topics it uses."""

    kind: str
    car: str  # the car's namespace ("" for the unnamed car)
    params: dict[str, Any]
    node: NodeSpec
    topic: str
    scan_topic: str
    odom_topic: str


@dataclass
class JoySpec:
    """A `joy/joy_node`: its car, topic and parameters. start() opens the gamepad its ~dev_name / ~dev name."""

    car: str
    node: NodeSpec
    topic: str
    config: JoyNodeConfig

    def start(self, sim: Simulator, ros: bool = False) -> JoyNode | None:
        """The JoyNode of the car, reading the gamepad; None (a warning) when there is none."""
        from racecar_sim.control.joy_device import GamepadUnavailable, open_gamepad  # pygame only when asked

        cfg = self.config
        try:
            device = open_gamepad(cfg.dev_name or cfg.dev, fallback=cfg.dev if cfg.dev_name else None)
        except GamepadUnavailable as exc:
            log.warning(
                "%s: %s: %s; %s takes sensor_msgs/Joy from the bus%s",
                self.node.where,
                self.node.label,
                exc,
                self.topic,
                " and from ROS" if ros else "",
            )
            return None
        log.info("%s: %s reads gamepad %s", self.node.where, self.node.label, device.name)
        node = sim.add_node(lambda ctx: JoyNode(ctx.bus, ctx.timers, ctx.now, device, cfg, self.topic), car=self.car)
        assert isinstance(node, JoyNode)
        return node


@dataclass
class JoyTeleopSpec:
    """A `racecar/joy_teleop.py`: its car, the Joy topic it reads and its commands with their bus topics."""

    car: str
    node: NodeSpec
    joy_topic: str
    commands: tuple[JoyCommand, ...]
    topics: dict[str, str]  # command topic_name -> bus topic
    launch_topics: dict[str, str]  # command topic_name -> the absolute name in the launch

    def start(self, sim: Simulator) -> JoyTeleop:
        node = sim.add_node(
            lambda ctx: JoyTeleop(ctx.bus, self.commands, self.joy_topic, self.topics.__getitem__), car=self.car
        )
        assert isinstance(node, JoyTeleop)
        return node


@dataclass
class SimSetup:
    """What the runner builds: the world, the cars (with their nodes), drivers, relays, keyboard teleop inputs,
    the nodes for the ROS bridge, and the parameter tree."""

    plan: LaunchPlan
    world: WorldChoice
    cars: list[Car]
    drivers: list[DriverSpec] = field(default_factory=list)
    relays: list[tuple[str, str]] = field(default_factory=list)
    teleop_topics: list[str] = field(default_factory=list)
    joy_nodes: list[JoySpec] = field(default_factory=list)
    joy_teleops: list[JoyTeleopSpec] = field(default_factory=list)
    ros_nodes: list[NodeSpec] = field(default_factory=list)
    skipped: list[NodeSpec] = field(default_factory=list)


@dataclass
class _Parts:
    """The launch's nodes that belong to one car."""

    spawn: CarSpawn
    spawners: list[NodeSpec] = field(default_factory=list)
    robot_state: list[NodeSpec] = field(default_factory=list)
    servo: list[NodeSpec] = field(default_factory=list)
    odometry: list[NodeSpec] = field(default_factory=list)
    muxes: list[tuple[str, Path, NodeSpec]] = field(default_factory=list)
    relays: list[tuple[str, str, NodeSpec]] = field(default_factory=list)
    defaults: list[tuple[str, float, float, float, NodeSpec]] = field(default_factory=list)

    @property
    def names(self) -> CarNames:
        return self.spawn.names

    def rel(self, topic: str) -> str:
        """A topic as the car's own (car-relative, as CarNames takes it)."""
        return strip_ns(topic, self.names.namespace)

    def own(self, topic: str) -> str:
        return self.names.topic(self.rel(topic))

    @cached_property
    def mux_topics(self) -> tuple[set[str], list[str]]:
        """The absolute input topics and the output topic of each of the car's mux nodelets (read from their YAML)."""
        inputs, outputs = set(), []
        for ns, path, _ in self.muxes:
            mux_inputs, output = load_mux_inputs(path)
            inputs |= {canonical(f"{ns}/{i.topic}") for i in mux_inputs}
            outputs.append(canonical(f"{ns}/{output}"))
        return inputs, outputs


def map_plan(
    plan: LaunchPlan,
    ros: bool = False,
    profile: str = "seed",
    lidar: bool = True,
    camera: bool = True,
    odometry: str = "original",
    scratch: Path | None = None,
    sensors_off: tuple[str, ...] = (),
    vehicle: str | Path | VehicleParams = DEFAULT_VEHICLE,
) -> SimSetup:
    """The sim that runs `plan`; `ros`: nodes without a sim equivalent go to the bridge. `scratch`: a folder for
    controller YAMLs built from the parameter tree (a temporary one by default). `lidar`, `camera`, `sensors_off`:
    the sensor switches of each car (runtime/plugins.py). `vehicle`: every car's tyre and actuator set."""
    world = world_of(plan)
    spawns = [parse_spawn(plan, n) for n in plan.nodes_of("gazebo_ros", "spawn_model")]
    if not spawns:
        raise LaunchError(
            plan.file,
            "no gazebo_ros spawn_model node: there is no car to simulate",
            'spawn one: <node pkg="gazebo_ros" type="spawn_model" name="racecar_spawn" '
            'args="-urdf -param robot_description -model racecar"/>, or add --ros to start its nodes '
            "next to a running `racecar-sim run --ros`",
        )
    parts: dict[str, _Parts] = {}
    for spawn in spawns:
        if spawn.names.namespace in parts:
            raise LaunchError(
                spawn.node.where,
                f"a second car in namespace '/{spawn.names.namespace}'",
                'give each spawn_model its own <group ns="carN">',
            )
        parts[spawn.names.namespace] = _Parts(spawn)
    setup = SimSetup(plan, world, [])
    for node in plan.nodes:
        _sort_node(plan, node, parts, setup, ros)
    for spec in setup.joy_teleops:
        _check_joy_topics(spec, parts[spec.car])
    scratch = scratch or Path(tempfile.mkdtemp(prefix="racecar-sim-launch-"))
    for part in parts.values():
        car = Car(
            part.names.namespace,
            profile=profile,
            controllers=_controllers(plan, part, scratch),
            spawn=part.spawn.spawn,
            lidar=lidar,
            camera=camera,
            odometry=odometry,
            nodes=_car_nodes(plan, part),
            sensors_off=sensors_off,
            vehicle=vehicle,
        )
        car.urdf = part.spawn.urdf
        setup.cars.append(car)
        for source, target, _ in part.relays:
            if not _is_chain_relay(part, source, target):
                setup.relays.append((part.own(source), part.own(target)))
    return setup


def _car_of(node: NodeSpec, parts: dict[str, _Parts]) -> _Parts | None:
    """The car whose namespace holds the node (the unnamed car's is the root, holding every other)."""
    best = None
    for ns, part in parts.items():
        if ns and global_ns(node.namespace).startswith(f"/{ns}/"):
            return part
        if not ns:
            best = part
    return best


def _sort_node(plan: LaunchPlan, node: NodeSpec, parts: dict[str, _Parts], setup: SimSetup, ros: bool) -> None:
    key = (node.package, node.type)
    if key in (("gazebo_ros", "spawn_model"),) or (node.package == "gazebo_ros" and node.type in SERVERS):
        return
    if key in NO_OP:
        plan.notes.append(f"{node.where}: {node.label}: {NO_OP[key]}")
        return
    part = _car_of(node, parts)
    if part is None:
        if _is_sim_node(node):
            log.warning("%s: %s skipped: no car is spawned in its namespace %s", node.where, node.label, node.namespace)
        else:  # a rostopic default command too: there is no car to give it to
            _other(node, setup, ros)
        return
    if key == ("controller_manager", "spawner"):
        part.spawners.append(node)
    elif key in (("robot_state_publisher", "robot_state_publisher"), ("robot_state_publisher", "state_publisher")):
        part.robot_state.append(node)
    elif key == ("racecar_control", "servo_commands.py"):
        part.servo.append(node)
    elif key == ("racecar_gazebo", "gazebo_odometry.py"):
        part.odometry.append(node)
    elif key == ("racecar_control", "keyboard_teleop.py"):
        setup.teleop_topics.append(part.own(node.resolve(TELEOP)))
    elif key == JOY_NODE:
        setup.joy_nodes.append(_joy_node(plan, node, part))
    elif key in JOY_TELEOP:
        spec = _joy_teleop(plan, node, part)
        if spec is not None:
            setup.joy_teleops.append(spec)
    elif key == ("topic_tools", "relay") and node.args:
        source = node.resolve(node.args[0])
        target = node.resolve(node.args[1]) if len(node.args) > 1 else source + "_relay"
        part.relays.append((source, target, node))
    elif key == ("nodelet", "nodelet") and node.args[:1] == ("manager",):
        return
    elif (
        key == ("nodelet", "nodelet")
        and len(node.args) >= 2
        and node.args[0] in ("load", "standalone")
        and node.args[1] == MUX_NODELET
    ):
        part.muxes.append((node.full_name, _mux_config(plan, node), node))
    elif key == ("rostopic", "rostopic") and (default := _default_command(node)) is not None:
        part.defaults.append((node.resolve(node.args[-3]), *default, node))
    elif node.package == "racecar_sim" and node.type.replace("-", "_") in DRIVERS:
        setup.drivers.append(_driver(plan, node, part))
    else:
        _other(node, setup, ros)


def _is_sim_node(node: NodeSpec) -> bool:
    known = {
        ("controller_manager", "spawner"),
        ("robot_state_publisher", "robot_state_publisher"),
        ("robot_state_publisher", "state_publisher"),
        ("racecar_control", "servo_commands.py"),
        ("racecar_gazebo", "gazebo_odometry.py"),
        ("racecar_control", "keyboard_teleop.py"),
        ("topic_tools", "relay"),
        ("nodelet", "nodelet"),
        JOY_NODE,
        *JOY_TELEOP,
    }
    return (node.package, node.type) in known or node.package == "racecar_sim"


def _other(node: NodeSpec, setup: SimSetup, ros: bool) -> None:
    """A node the sim has no equivalent for: the bridge starts it with --ros; otherwise skipped, or an error if
    the launch says the run needs it (required="true")."""
    if ros:
        setup.ros_nodes.append(node)
        return
    if node.required:
        raise LaunchError(
            node.where,
            f"node {node.label} is required and the sim has no equivalent of it",
            'run with --ros to start it as a ROS node (needs ROS 1), or drop required="true"',
        )
    log.warning(
        "%s: node %s not started: the sim has no equivalent; run with --ros to start it as a ROS node",
        node.where,
        node.label,
    )
    setup.skipped.append(node)


def _mux_config(plan: LaunchPlan, node: NodeSpec) -> Path:
    value = plan.params.get(node.private("yaml_cfg_file"))
    if not isinstance(value, str) or not value:
        raise LaunchError(
            node.where,
            "the ackermann_cmd_mux nodelet has no yaml_cfg_file param",
            'add <param name="yaml_cfg_file" value="$(find racecar)/config/racecar-v2/'
            'low_level_mux.yaml"/> to the node',
        )
    path = Path(value)
    if not path.is_file():
        raise LaunchError(node.where, f"yaml_cfg_file {value} does not exist", "check the path")
    return path


def _default_command(node: NodeSpec) -> tuple[float, float, float] | None:
    """`rostopic pub -r RATE TOPIC ackermann_msgs/AckermannDriveStamped '{drive: {...}}'` as (rate, speed, steer)."""
    args = list(node.args)
    if len(args) < 4 or args[0] != "pub" or "-r" not in args or args[-2] != ACKERMANN:
        return None
    try:
        rate = float(args[args.index("-r") + 1])
        drive = (yaml.safe_load(args[-1]) or {}).get("drive") or {}
        return rate, float(drive.get("speed", 0.0)), float(drive.get("steering_angle", 0.0))
    except (ValueError, IndexError, AttributeError, yaml.YAMLError):
        return None


def _driver(plan: LaunchPlan, node: NodeSpec, part: _Parts) -> DriverSpec:
    return DriverSpec(
        node.type.replace("-", "_"),
        part.names.namespace,
        plan.subtree(node.full_name),
        node,
        part.own(node.resolve(NAVIGATION)),
        part.own(node.resolve("/scan")),
        part.own(node.resolve(ODOM)),
    )


# --- the joystick ---------------------------------------------------------------------------------------
def _joy_node(plan: LaunchPlan, node: NodeSpec, part: _Parts) -> JoySpec:
    where = f"{node.where}: {node.label}"
    try:
        config = JoyNodeConfig.from_params(plan.subtree(node.full_name), where)
    except ConfigError as exc:
        raise LaunchError(node.where, " ".join(str(exc).split()), "fix the node's private params") from None
    return JoySpec(part.names.namespace, node, part.own(node.resolve("joy")), config)


def _joy_teleop(plan: LaunchPlan, node: NodeSpec, part: _Parts) -> JoyTeleopSpec | None:
    """joy_teleop.py reads its commands from the `teleop` parameter of its namespace (None: it has none, and takes
    its node down, as the original does)."""
    name = node.resolve("teleop")
    tree = plan.param(name)
    if tree is None:
        if node.required:
            raise LaunchError(node.where, f"{node.label} has no {name} parameter", "load joy_teleop.yaml first")
        log.warning(
            "%s: %s: no %s parameter, node not started (load joy_teleop.yaml with <rosparam> first, as "
            "joy_teleop.launch.xml does)",
            node.where,
            node.label,
            name,
        )
        return None
    try:
        commands = parse_commands(tree, name)
    except ConfigError as exc:
        raise LaunchError(node.where, " ".join(str(exc).split()), "fix joy_teleop.yaml") from None
    launch_topics = {c.topic_name: node.resolve(c.topic_name) for c in commands}
    topics = {written: part.own(absolute) for written, absolute in launch_topics.items()}
    return JoyTeleopSpec(part.names.namespace, node, part.own(node.resolve("joy")), commands, topics, launch_topics)


def _check_joy_topics(spec: JoyTeleopSpec, part: _Parts) -> None:
    """Warn when a drive command of joy_teleop.py goes where no mux of the car takes it (the original's
    racecar_control teleop.launch includes joy_teleop.launch.xml outside `<group ns="vesc">`)."""
    inputs, _ = part.mux_topics
    taken = inputs | {canonical(s) for s, _, _ in part.relays}
    drives = [c for c in spec.commands if c.cls.__msgtype__.startswith("ackermann_msgs/")]
    for topic in dict.fromkeys(spec.launch_topics[c.topic_name] for c in drives):
        if topic not in taken:
            log.warning(
                "%s: %s publishes its drive commands on %s, which no ackermann_cmd_mux of the launch takes: the "
                "joystick drives nothing (racecar-v2-teleop.launch.xml includes joy_teleop.launch.xml in "
                '<group ns="vesc">)',
                spec.node.where,
                spec.node.label,
                topic,
            )


# --- one car's nodes ------------------------------------------------------------------------------
def _is_chain_relay(part: _Parts, source: str, target: str) -> bool:
    inputs, outputs = part.mux_topics
    return bool(part.muxes) and (source in inputs | set(outputs) or target in inputs | set(outputs))


def _car_nodes(plan: LaunchPlan, part: _Parts) -> CarNodes:
    servo_input = part.rel(part.servo[-1].resolve(SERVO_INPUT)) if part.servo else None
    robot_state = part.robot_state[-1].resolve("joint_states") if part.robot_state else None
    controllers, stopped = _spawned(part)
    return CarNodes(
        mux=_wiring(plan, part, servo_input),
        servo_input=servo_input,
        controllers=controllers,
        stopped=stopped,
        robot_state=bool(part.robot_state),
        joint_states=part.rel(robot_state) if robot_state else None,
        odometry=bool(part.odometry),
        odom_relay=None,
    )


def _wiring(plan: LaunchPlan, part: _Parts, servo_input: str | None) -> dict[str, Any] | None:
    """control/mux.py's wiring for the car's mux nodelets, their relays and default command (None: no muxes)."""
    if not part.muxes:
        for _, _, _, _, node in part.defaults:
            log.warning("%s: %s: a default command with no mux to feed, skipped", node.where, node.label)
        return None
    outputs = part.mux_topics[1]
    relays = [[part.rel(s), part.rel(t)] for s, t, _ in part.relays if _is_chain_relay(part, s, t)]
    sources = {s for s, _ in relays}
    if servo_input is not None and servo_input in {part.rel(o) for o in outputs}:
        output = servo_input
    else:
        finals = [part.rel(o) for o in outputs if part.rel(o) not in sources]
        output = (finals or [part.rel(o) for o in outputs])[-1]
    wiring: dict[str, Any] = {
        "source": str(plan.file),
        "output": output,
        "relays": relays,
        "muxes": {part.rel(ns): str(path) for ns, path, _ in part.muxes},
    }
    if part.defaults:
        topic, rate, speed, steering, _ = part.defaults[-1]
        wiring["default_command"] = {"topic": part.rel(topic), "rate": rate, "speed": speed, "steering_angle": steering}
    return wiring


def _spawned(part: _Parts) -> tuple[tuple[str, ...], tuple[str, ...]]:
    started: list[str] = []
    stopped: list[str] = []
    for node in part.spawners:
        names, skip, is_stopped = [], False, "--stopped" in node.args
        for word in node.args:
            if skip:
                skip = False
            elif word in ("--shutdown-timeout", "--timeout", "--namespace"):
                skip = True
            elif not word.startswith("-"):
                names.append(word)
        (stopped if is_stopped else started).extend(n for n in names if n not in started + stopped)
    if not part.spawners:
        log.warning(
            "%s: no controller_manager spawner for car %s: its controllers are not started (it will not move)",
            part.spawn.node.where,
            part.names.model,
        )
    return tuple(started), tuple(stopped)


def _controller_ns(part: _Parts) -> str:
    if not part.spawners:
        return global_ns(f"/{part.names.namespace}/racecar" if part.names.namespace else "/racecar")
    node = part.spawners[0]
    args = list(node.args)
    if "--namespace" in args and args.index("--namespace") + 1 < len(args):
        return global_ns(node.resolve(args[args.index("--namespace") + 1]))
    return global_ns(node.namespace)


def _controllers(plan: LaunchPlan, part: _Parts, scratch: Path) -> Path:
    """The car's controller YAML: the <rosparam> file the spawner's parameters came from when they are exactly that
    file, else one written from the parameter tree (the shipped racecar_control.yaml when there are none)."""
    ns = _controller_ns(part)
    tree = plan.subtree(ns)
    entries = {name: value for name, value in tree.items() if isinstance(value, dict) and "type" in value}
    where = part.spawners[0].where if part.spawners else part.spawn.node.where
    if not entries:
        if part.spawners:
            raise LaunchError(
                where,
                f"no controller parameters under {ns}",
                'load them first: <rosparam file="$(find racecar_control)/config/racecar_control.yaml" '
                'command="load"/>',
            )
        return DEFAULT_CONTROLLERS
    for name in _spawned(part)[0] + _spawned(part)[1]:
        if name not in entries:
            raise LaunchError(
                where,
                f"controller {name} has no parameters at {ns}{name}",
                "load its parameters (type, joint, pid) with <rosparam>, or drop it from the spawner",
            )
    key = strip_ns(ns, part.names.namespace).strip(SEP)
    if not key:
        raise LaunchError(
            where,
            "the spawner runs in the car's root namespace",
            'run it in the controllers\' namespace (ns="/racecar"), as racecar_control.launch does',
        )
    leaves = [k for k in plan.params if k.startswith(ns)]
    files = {plan.sources.get(k) for k in leaves}
    source = files.pop() if len(files) == 1 else None
    if source is not None:
        try:
            if yaml.safe_load(source.read_text()) == {key: tree}:
                return source
        except (OSError, yaml.YAMLError):
            pass
    path = scratch / f"{part.names.model}_controllers.yaml"
    path.write_text(
        f"# {part.names.model}'s controller parameters under {ns}, from {plan.file}\n"
        + yaml.safe_dump({key: entries}, sort_keys=False)
    )
    return path
