"""gazebo_ros nodes: the gzserver node's world and pause flag, and spawn_model's car (URDF, namespace, pose)."""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass
from pathlib import Path

from racecar_sim.core.errors import ConfigError
from racecar_sim.core.names import CarNames
from racecar_sim.launch.errors import LaunchError
from racecar_sim.launch.plan import LaunchPlan, NodeSpec
from racecar_sim.launch.rosnames import SEP
from racecar_sim.worlds import Spawn
from racecar_sim.worlds.catalog import world_names

log = logging.getLogger("racecar_sim.launch")
SERVERS = ("gzserver", "debug", "gazebo")
EMPTY = "empty"
_POSE_FLAGS = {"-x": 0, "-y": 1, "-z": 2, "-R": 3, "-P": 4, "-Y": 5}
_VALUE_FLAGS = (
    "-param",
    "-file",
    "-model",
    "-robot_namespace",
    "-reference_frame",
    "-gazebo_namespace",
    "-database",
    "-J",
    "-package_to_model",
)
_SWITCHES = ("-urdf", "-sdf", "-gazebo", "-trimesh", "-unpause", "-wait", "-b")


@dataclass(frozen=True)
class WorldChoice:
    """The world the gzserver node loads (a file or a built-in world's name) and whether it starts paused."""

    world: str
    paused: bool


def world_of(plan: LaunchPlan) -> WorldChoice:
    """The world of the launch's gzserver node (empty_world.launch's `gazebo`); the empty world without one."""
    servers = plan.nodes_of("gazebo_ros", *SERVERS)
    if not servers:
        log.info("%s: no gazebo_ros server node (empty_world.launch): the sim runs the empty world", plan.file)
        return WorldChoice(EMPTY, False)
    node = servers[0]
    args = list(node.args)
    paused = "-u" in args
    positional, skip = [], False
    for word in args:
        if skip:
            skip = False
        elif word in ("-e", "--physics", "-s", "--server-plugin", "-p", "--play", "--seed", "--iters"):
            skip = True
        elif not word.startswith("-"):
            positional.append(word)
    world = positional[-1] if positional else "worlds/empty.world"
    if Path(world).is_file():
        return WorldChoice(str(Path(world)), paused)
    name = Path(world).stem
    if name in world_names():
        return WorldChoice(name, paused)
    raise LaunchError(
        node.where,
        f"world {world} is neither a file nor a built-in world",
        f"give world_name a .world file ($(find pkg)/worlds/NAME.world) or one of {', '.join(world_names())}",
    )


@dataclass(frozen=True)
class CarSpawn:
    """One spawn_model: the car's namespace (its names), URDF text, pose and the node that asked."""

    names: CarNames
    urdf: str
    spawn: Spawn
    node: NodeSpec


def parse_spawn(plan: LaunchPlan, node: NodeSpec) -> CarSpawn:
    """spawn_model's command line (-urdf -param NAME | -file F, -model, -x -y -z -R -P -Y, -robot_namespace)."""
    flags: dict[str, str] = {}
    pose = [0.0] * 6
    args = list(node.args)
    i = 0
    while i < len(args):
        word = args[i]
        if word in _POSE_FLAGS or word in _VALUE_FLAGS:
            if i + 1 >= len(args):
                raise LaunchError(node.where, f"spawn_model {word} needs a value", f"write {word} VALUE")
            if word in _POSE_FLAGS:
                try:
                    pose[_POSE_FLAGS[word]] = float(args[i + 1])
                except ValueError:
                    raise LaunchError(
                        node.where, f"spawn_model {word} {args[i + 1]} is not a number", "give a number"
                    ) from None
            else:
                flags[word] = args[i + 1]
            i += 2
            continue
        if word in _SWITCHES:
            flags[word] = ""
        i += 1
    if "-sdf" in flags or "-database" in flags:
        raise LaunchError(
            node.where,
            "spawn_model of an SDF model is not a car the sim can drive",
            "spawn the car with -urdf (a robot_description param or -file)",
        )
    urdf = _urdf_text(plan, node, flags)
    namespace = flags.get("-robot_namespace", node.namespace).strip(SEP)
    try:
        names = CarNames(namespace)
    except ConfigError as exc:
        raise LaunchError(
            node.where, f"robot namespace '{namespace}': {exc}", 'spawn each car in a one-level <group ns="car1">'
        ) from None
    model = flags.get("-model")
    if model and model != names.model:
        log.warning(
            "%s: the car of namespace '/%s' is Gazebo model '%s' in the sim, not '%s' (its name derives from "
            "its namespace)",
            node.where,
            namespace,
            names.model,
            model,
        )
    if pose[3] or pose[4]:
        log.warning("%s: spawn_model -R/-P ignored: a car spawns level, with only its heading (-Y)", node.where)
    if not all(math.isfinite(v) for v in pose):
        raise LaunchError(node.where, "spawn_model pose is not finite", "give finite -x -y -z -Y")
    return CarSpawn(names, urdf, Spawn(pose[0], pose[1], pose[2], pose[5]), node)


def _urdf_text(plan: LaunchPlan, node: NodeSpec, flags: dict[str, str]) -> str:
    if "-param" in flags:
        name = node.resolve(flags["-param"])
        value = plan.params.get(name)
        if not isinstance(value, str) or not value.strip():
            raise LaunchError(
                node.where,
                f"spawn_model -param {flags['-param']}: parameter {name} is not set",
                f'set it first, e.g. <param name="{flags["-param"]}" command="$(find xacro)/xacro FILE.xacro"/>',
            )
        return value
    if "-file" in flags:
        try:
            return Path(flags["-file"]).read_text()
        except OSError as exc:
            raise LaunchError(
                node.where,
                f"spawn_model -file {flags['-file']}: cannot read it ({exc.strerror or exc})",
                "check the path",
            ) from None
    raise LaunchError(node.where, "spawn_model names no robot description", "add -urdf -param robot_description")
