"""racecar's joy_teleop.py (Python 2, from ros-teleop's teleop_tools) as a node: sensor_msgs/Joy to commands.

It reads the `teleop` parameter, as racecar/config/racecar-v2/joy_teleop.yaml sets it beside joy_node's parameters
(`<rosparam>` in `<group ns="vesc">`, so both are under /vesc). Each entry is a command:

    human_control:                          # a name
      type: topic                           # only topics are run here (actions and services: a warning)
      message_type: ackermann_msgs/AckermannDriveStamped
      topic_name: low_level/ackermann_cmd_mux/input/teleop    # relative to the node's namespace: /vesc/...
      deadman_buttons: [4]                  # the buttons that must be held, and no other
      axis_mappings:                        # target = axes[axis] * scale + offset
        - {axis: 1, target: drive.speed, scale: 2.0, offset: 0.0}
        - {axis: 3, target: drive.steering_angle, scale: 0.34, offset: 0.0}
    default:                                # is_default: runs when no command's buttons match
      type: topic
      is_default: true
      message_type: ackermann_msgs/AckermannDriveStamped
      topic_name: low_level/ackermann_cmd_mux/input/teleop
      message_value: [{target: drive.speed, value: 0.0}, {target: drive.steering_angle, value: 0.0}]

On every Joy message (joy_node repeats them at autorepeat_rate) the command whose deadman buttons are exactly the
buttons held runs (the indices of the pressed buttons, in order, equal to the list); if none does, the first
`is_default` command runs, if there is one; otherwise nothing is published, the mux's teleop input times out and
the 6 Hz default zero command stops the car. A command builds a fresh message (header empty, as the original's),
sets each target, and publishes it. An axis the joystick does not have gives 0 (a warning, once).
"""

from __future__ import annotations

import logging
import numbers
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import yaml

from racecar_sim.bus import BusPort
from racecar_sim.control.joy import JOY, JoyNodeConfig
from racecar_sim.core.errors import ConfigError
from racecar_sim.core.names import CarNames
from racecar_sim.core.tables import finite_number
from racecar_sim.description.ros_packages import find_package
from racecar_sim.msgs import Joy, message_class
from racecar_sim.msgs._base import Message
from racecar_sim.nodes import NodeBase

log = logging.getLogger("racecar_sim.joy")
VESC = "/vesc"  # the namespace racecar-v2-teleop.launch.xml runs joy_node and joy_teleop.py in
CONFIG = Path("config") / "racecar-v2" / "joy_teleop.yaml"  # in the racecar package


@dataclass(frozen=True)
class AxisMapping:
    """`target` = axes[`axis`] * `scale` + `offset`."""

    axis: int
    target: str
    scale: float = 1.0
    offset: float = 0.0


@dataclass(frozen=True)
class JoyCommand:
    """One `topic` command of the `teleop` parameter."""

    name: str
    topic_name: str  # as written: relative names are resolved in the node's namespace
    cls: type[Message]
    buttons: tuple[int, ...]
    is_default: bool = False
    axis_mappings: tuple[AxisMapping, ...] = ()
    values: tuple[tuple[str, Any], ...] | None = None  # message_value: fixed values instead of axes

    def message(self, axes: Any, warn: Callable[[str], None]) -> Message:
        msg = self.cls()
        if self.values is not None:
            for target, value in self.values:
                _set_member(msg, target, value)
            return msg
        for mapping in self.axis_mappings:
            if mapping.axis < len(axes):
                value = float(axes[mapping.axis]) * mapping.scale + mapping.offset
            else:
                warn(
                    f"joy_teleop: the joystick has only {len(axes)} axes (indexed from 0), but #{mapping.axis} "
                    f"was referenced in command {self.name}: 0 taken"
                )
                value = 0.0
            _set_member(msg, mapping.target, value)
        return msg


def _set_member(msg: Message, target: str, value: Any) -> None:
    """Set a dotted field of a message (`drive.speed`); the field must hold a number or a string."""
    *parents, leaf = target.split(".")
    holder: Any = msg
    for part in parents:
        holder = getattr(holder, part)
    current = getattr(holder, leaf)
    if isinstance(current, str) and isinstance(value, str):
        setattr(holder, leaf, value)
    elif isinstance(current, numbers.Real) and not isinstance(current, bool) and not isinstance(value, (str, bool)):
        setattr(holder, leaf, int(value) if isinstance(current, numbers.Integral) else float(value))
    else:
        raise TypeError(f"{target} holds {type(current).__name__}, not a value like {value!r}")


def _whole(value: Any, where: str) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or value < 0:
        raise ConfigError(f"{where}: expected a whole number >= 0, got {value!r}")
    return value


def _text(entry: Mapping[str, Any], key: str, where: str) -> str:
    value = entry.get(key)
    if not isinstance(value, str) or not value:
        raise ConfigError(f"{where}: {key}: expected a name, got {value!r}")
    return value


def parse_commands(teleop: Any, where: str) -> tuple[JoyCommand, ...]:
    """The commands of a `teleop` parameter; ConfigError names `where`, the command and the field."""
    if not isinstance(teleop, Mapping) or not teleop:
        raise ConfigError(f"{where}: no commands (joy_teleop.py takes its node down without a 'teleop' parameter)")
    commands = []
    for name, entry in teleop.items():
        at = f"{where}: {name}"
        if not isinstance(entry, Mapping):
            raise ConfigError(f"{at}: expected a mapping (type, message_type, topic_name, ...)")
        kind = entry.get("type")
        if kind in ("action", "service"):
            log.warning("%s: a %s command is not run in the sim (only topic commands are)", at, kind)
            continue
        if kind != "topic":
            raise ConfigError(f"{at}: unknown type {kind!r} (topic, action or service)")
        topic_name = _text(entry, "topic_name", at)
        message_type = _text(entry, "message_type", at)
        try:
            cls = message_class(message_type)
        except KeyError:
            log.warning("%s: message type %s is not one the sim has: command skipped", at, message_type)
            continue
        buttons = entry.get("deadman_buttons") or []
        if not isinstance(buttons, list):
            raise ConfigError(f"{at}: deadman_buttons: expected a list of button numbers, got {buttons!r}")
        is_default = entry.get("is_default", False)
        if not isinstance(is_default, bool):
            raise ConfigError(f"{at}: is_default: expected true or false, got {is_default!r}")
        command = JoyCommand(
            str(name),
            topic_name,
            cls,
            tuple(_whole(b, f"{at}: deadman_buttons") for b in buttons),
            is_default,
            *_targets(entry, at),
        )
        try:  # every target set once, so that a misspelt one is named now, not at the first button press
            command.message([0.0] * (1 + max((m.axis for m in command.axis_mappings), default=0)), lambda _: None)
        except (AttributeError, TypeError, ValueError) as exc:
            raise ConfigError(f"{at}: {' '.join(str(exc).split())} in {cls.__msgtype__}") from None
        commands.append(command)
    return tuple(commands)


def _targets(entry: Mapping[str, Any], at: str) -> tuple[tuple[AxisMapping, ...], tuple[tuple[str, Any], ...] | None]:
    if "message_value" in entry:
        values = entry["message_value"]
        if not isinstance(values, list) or not all(isinstance(v, Mapping) and "target" in v for v in values):
            raise ConfigError(f"{at}: message_value: expected a list of {{target: ..., value: ...}}")
        return (), tuple((_text(v, "target", f"{at}: message_value"), v.get("value")) for v in values)
    mappings = entry.get("axis_mappings")
    if not isinstance(mappings, list) or not all(isinstance(m, Mapping) for m in mappings):
        raise ConfigError(
            f"{at}: a topic command needs axis_mappings (a list of {{axis, target, scale, offset}}) or message_value"
        )
    axes = []
    for m in mappings:
        where = f"{at}: axis_mappings"
        axes.append(
            AxisMapping(
                _whole(m.get("axis"), f"{where}: axis"),
                _text(m, "target", where),
                finite_number(m.get("scale", 1.0), f"{where}: scale"),
                finite_number(m.get("offset", 0.0), f"{where}: offset"),
            )
        )
    return tuple(axes), None


def joy_teleop_yaml() -> Path:
    """racecar/config/racecar-v2/joy_teleop.yaml, as `$(find racecar)` finds it: a racecar package on the package
    path first, else the stand-in racecar-sim ships."""
    return find_package("racecar") / CONFIG


def load_joy_teleop(path: Path | None = None) -> tuple[JoyNodeConfig, tuple[JoyCommand, ...]]:
    """joy_node's parameters and the teleop commands of a joy_teleop.yaml (default: `joy_teleop_yaml()`)."""
    path = Path(path) if path is not None else joy_teleop_yaml()
    try:
        data = yaml.safe_load(path.read_text())
    except (OSError, yaml.YAMLError) as exc:
        raise ConfigError(f"{path}: cannot read: {' '.join(str(exc).split())}") from None
    if not isinstance(data, Mapping):
        raise ConfigError(f"{path}: expected a mapping with joy_node and teleop")
    joy_params = data.get("joy_node") or {}
    if not isinstance(joy_params, Mapping):
        raise ConfigError(f"{path}: joy_node: expected a mapping of joy_node's parameters")
    joy = JoyNodeConfig.from_params(joy_params, f"{path}: joy_node")
    return joy, parse_commands(data.get("teleop"), f"{path}: teleop")


def in_namespace(ns: str = VESC, names: CarNames | None = None) -> Callable[[str], str]:
    """How a node in namespace `ns` resolves a topic name (a global one stays), as the car `names` has it."""
    names = names or CarNames()

    def resolve(name: str) -> str:
        absolute = name if name.startswith("/") else f"{ns.rstrip('/')}/{name}"
        return names.topic(absolute)

    return resolve


class JoyTeleop(NodeBase):
    """Maps sensor_msgs/Joy on `joy_topic` (/vesc/joy) onto the commands' topics, as joy_teleop.py does.

    resolve: a command's topic_name to the bus topic (default: names relative to /vesc). `command` is the name of
    the command the last Joy message ran (None: none did), `received` counts the Joy messages."""

    def __init__(
        self,
        bus: BusPort,
        commands: tuple[JoyCommand, ...],
        joy_topic: str = JOY,
        resolve: Callable[[str], str] | None = None,
    ) -> None:
        resolve = resolve or in_namespace()
        self.bus, self.commands, self.joy_topic = bus, commands, joy_topic
        self.topics = {c.name: resolve(c.topic_name) for c in commands}
        self.command: str | None = None
        self.received = 0
        self._warned: set[str] = set()
        bus.subscribe(joy_topic, self._on_joy, msgtype=Joy)

    def _warn(self, text: str) -> None:
        if text not in self._warned:
            self._warned.add(text)
            log.warning("%s", text)

    def match(self, buttons: Any) -> JoyCommand | None:
        """The command the buttons held run: the one whose deadman buttons they are exactly, else the first
        default command."""
        held = tuple(i for i, b in enumerate(buttons) if b)
        exact = next((c for c in self.commands if c.buttons == held), None)
        return exact or next((c for c in self.commands if c.is_default), None)

    def _on_joy(self, joy: Joy) -> None:
        if type(joy) is not Joy:
            self._warn(f"{self.joy_topic}: ignored a {type(joy).__name__} message (the topic takes sensor_msgs/Joy)")
            return
        self.received += 1
        command = self.match(joy.buttons)
        self.command = command.name if command is not None else None
        if command is not None:
            self.bus.publish(self.topics[command.name], command.message(joy.axes, self._warn))
