"""ackermann_cmd_mux and the mux.launch wiring of the original (original_stack.md §4.1).

A message is forwarded unchanged, at once, when no input holds control, when its input already holds
it, or when its input outranks the holder. Each input's timer restarts on every message; when the
holder's timer runs out, control is vacant ("idle") until some input sends again. The mux never
re-publishes on its own.

The relays and muxes hand a command on through their chain's CommandRows (command_rows.py): where a recorder alone
takes a topic besides the next node, that node gets the message itself and the recorder its numbers, one hand-over
per command.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from functools import lru_cache, partial
from pathlib import Path
from typing import Any

import yaml

from racecar_sim.bus import BusPort, ListenerAnswer, type_name
from racecar_sim.control.command_rows import CommandRows, Forwarding, joins_command_rows
from racecar_sim.core import yaml_text
from racecar_sim.core.errors import ConfigError
from racecar_sim.core.names import CarNames
from racecar_sim.core.tables import finite_number
from racecar_sim.core.throttle import ThrottledWarning, is_finite_number
from racecar_sim.core.time import to_ns
from racecar_sim.msgs import AckermannDrive, AckermannDriveStamped, Header, String
from racecar_sim.nodes import NodeBase, Restartable, Timers

DATA = Path(__file__).parent / "data"
MUX_WIRING = DATA / "mux.yaml"  # the original racecar.launch's chain
IDLE_ZERO = "idle (zero command)"  # nobody drives: the 6 Hz default zero command holds the car
log = logging.getLogger("racecar_sim.ackermann_cmd_mux")
_DRIVE_FIELDS = ("speed", "steering_angle", "steering_angle_velocity", "acceleration", "jerk")


def non_finite_field(msg: AckermannDriveStamped) -> str | None:
    """The first drive field of `msg` that is NaN or infinite (or not a number at all), else None."""
    drive = getattr(msg, "drive", None)
    if type(drive) is AckermannDrive:  # every command passes here: the common case in a few plain float checks
        a, b, c, d, e = drive.speed, drive.steering_angle, drive.steering_angle_velocity, drive.acceleration, drive.jerk
        if (
            type(a) is float
            and type(b) is float
            and type(c) is float
            and type(d) is float
            and type(e) is float
            and math.isfinite(a + b + c + d + e)
        ):  # a sum of finite numbers may overflow: then field by field
            return None
    for name in _DRIVE_FIELDS:
        value = getattr(msg.drive, name, None)
        if not is_finite_number(value):
            return f"drive.{name} = {value!r}"
    return None


def accept_command(topic: str, msg: AckermannDriveStamped, warn: ThrottledWarning) -> bool:
    """Whether a command may enter the command path; a non-finite one, or a message of another type, is dropped with
    a throttled warning, so it neither drives the car nor refreshes any mux timeout (a NaN driver stops the car like a
    silent one)."""
    if msg is Forwarding.msg:  # accepted by the node that is forwarding it to us
        return True
    if type(msg) is not AckermannDriveStamped:
        warn(
            f"{topic} type",
            "%s: ignored a %s message (the topic takes %s)",
            topic,
            type_name(msg),
            type_name(AckermannDriveStamped),
        )
        return False
    bad = non_finite_field(msg)
    if bad is None:
        return True
    warn(topic, "%s: ignored a command with %s (not a finite number)", topic, bad)
    return False


def _number(entry: dict[str, Any], key: str, where: str, integer: bool = False, positive: bool = False) -> float:
    value = entry.get(key) if isinstance(entry, dict) else None
    if integer:
        if isinstance(value, bool) or not isinstance(value, int):
            raise ConfigError(f"{where}: {key} must be a whole number, got {value!r}")
        return value
    number = finite_number(value, f"{where}: {key}")
    if positive and number <= 0:
        raise ConfigError(f"{where}: {key} must be positive, got {value!r}")
    return number


@dataclass(frozen=True)
class MuxInput:
    """One subscriber of the mux: name, topic relative to the mux, timeout (s) and priority."""

    name: str
    topic: str
    timeout: float
    priority: int


@lru_cache(maxsize=32)
def _parsed(text: str) -> Any:
    """A mux file's YAML, parsed once per text: every car of a fleet reads the same files (read only here)."""
    return yaml_text.safe_load(text)


def load_mux_inputs(path: Path) -> tuple[list[MuxInput], str]:
    """Read a yocs-style mux YAML: the subscribers and the output topic name."""
    try:
        data = _parsed(path.read_text())
        subscribers = data["subscribers"]
        output = data.get("publisher", "output")
    except (OSError, yaml.YAMLError, KeyError, TypeError, AttributeError) as exc:
        raise ConfigError(f"{path}: malformed mux config: {' '.join(str(exc).split())}") from None
    if not isinstance(subscribers, list) or not subscribers:
        raise ConfigError(f"{path}: subscribers must be a non-empty list")
    inputs = []
    for i, entry in enumerate(subscribers):
        where = f"{path}: subscribers[{i}]"
        for key in ("name", "topic"):
            if not isinstance(entry, dict) or not isinstance(entry.get(key), str) or not entry[key]:
                raise ConfigError(f"{where}: {key} must be a non-empty string")
        where = f"{path}: subscribers[{i}] ({entry['name']})"
        inputs.append(
            MuxInput(
                entry["name"],
                entry["topic"],
                float(_number(entry, "timeout", where, positive=True)),
                int(_number(entry, "priority", where, integer=True)),
            )
        )
    return inputs, str(output)


class AckermannCmdMux:
    """One ackermann_cmd_mux nodelet under `namespace` (e.g. /vesc/low_level/ackermann_cmd_mux)."""

    def __init__(
        self,
        bus: BusPort,
        scheduler: Timers,
        now: Callable[[], int],
        namespace: str,
        inputs: list[MuxInput],
        output: str = "output",
        rows: CommandRows | None = None,
    ) -> None:
        self.bus, self.scheduler, self.now = bus, scheduler, now
        self.rows = rows or CommandRows(bus)  # its chain's: how it hands a command on (command_rows.py)
        self.warn = ThrottledWarning(log, now)
        self.namespace = namespace
        self.output_topic = f"{namespace}/{output}"
        self.active_topic = f"{namespace}/active"
        self._output = self.rows.answer(self.output_topic)
        self.holder: MuxInput | None = None
        self.last_forwarded: MuxInput | None = None  # whose command went out last (it still drives downstream)
        self._timers: dict[str, Restartable] = {}  # per input, restarted by each of its commands
        bus.latch(self.active_topic)
        bus.publish(self.active_topic, String("idle"))
        for inp in inputs:
            topic = f"{namespace}/{inp.topic}"
            timer = self._timers[inp.name] = scheduler.timeout(
                partial(self._on_timeout, inp), f"{namespace} {inp.name} timeout"
            )
            take = joins_command_rows(partial(self._on_command, inp, (topic, to_ns(inp.timeout), timer)))
            bus.subscribe(topic, take, AckermannDriveStamped)

    def _on_command(self, inp: MuxInput, plan: tuple[str, int, Restartable], msg: AckermannDriveStamped) -> None:
        topic, timeout_ns, timer = plan  # worked out once per input
        if msg is not Forwarding.msg and not accept_command(topic, msg, self.warn):  # the first test: accept's own
            return
        timer.restart(self.now() + timeout_ns)
        holder = self.holder
        if holder is None or holder is inp or inp.priority > holder.priority:
            if holder is not inp:
                self.holder = inp
                self.rows.publish(self.active_topic, String(inp.name))
            self.last_forwarded = inp
            self.rows.forward(self.output_topic, msg, self._output)

    def _on_timeout(self, inp: MuxInput, _now: int) -> None:
        if self.holder is inp:
            self.holder = None
            self.bus.publish(self.active_topic, String("idle"))

    def reset(self) -> None:
        """As a freshly started nodelet: no timers, nobody in control, `active` idle."""
        for timer in self._timers.values():
            timer.stop()
        self.holder = self.last_forwarded = None
        self.bus.publish(self.active_topic, String("idle"))


class CommandChain(NodeBase):
    """mux.launch: the high- and low-level muxes, the topic relays and the 6 Hz default zero command.

    `config`: the wiring as a YAML file (mux.yaml) or the same as a mapping (a launch file's nodes; its mux files
    absolute paths, `source` naming where it came from, `default_command` optional)."""

    def __init__(
        self,
        bus: BusPort,
        scheduler: Timers,
        now: Callable[[], int],
        config: Path | Mapping = MUX_WIRING,
        names: CarNames = CarNames(),
    ) -> None:
        try:
            if isinstance(config, Mapping):
                data, folder = config, Path(".")
                config = config.get("source", "the mux wiring")
            else:
                data, folder = _parsed(config.read_text()), config.parent
            self.output_topic: str = names.topic(data["output"])
            default = data.get("default_command")
            muxes, relays = data["muxes"], data["relays"]
        except (OSError, yaml.YAMLError, KeyError, TypeError, AttributeError) as exc:
            raise ConfigError(f"{config}: malformed mux wiring: {' '.join(str(exc).split())}") from None
        self.warn = ThrottledWarning(log, now)
        self.default_topic: str | None = None
        if default is not None:
            where = f"{config}: default_command"
            rate = _number(default, "rate", where, positive=True)
            if not isinstance(default.get("topic"), str):
                raise ConfigError(f"{where}: topic must be a topic name, got {default.get('topic')!r}")
            self.default_topic = default_topic = names.topic(default["topic"])
            speed, steering = _number(default, "speed", where), _number(default, "steering_angle", where)
        self.rows = CommandRows(bus)  # a command's recorded messages, as rows where a recorder alone takes them
        self.muxes = []
        for namespace, file in muxes.items():
            inputs, output = load_mux_inputs(folder / file)
            self.muxes.append(AckermannCmdMux(bus, scheduler, now, names.topic(namespace), inputs, output, self.rows))
        relays = [(names.topic(source), names.topic(target)) for source, target in relays]
        for source, target in relays:
            relay = partial(self._relay, source, target, self.rows.answer(target))
            bus.subscribe(source, joins_command_rows(relay), AckermannDriveStamped)
        self.bus = bus
        self._feeders = {target: mux for source, target in relays for mux in self.muxes if mux.output_topic == source}
        final = next((m for m in self.muxes if m.output_topic == self.output_topic), None)
        if final is None:
            raise ConfigError(f"{config}: output {self.output_topic} is no mux's output")
        self._final = final
        if default is None:
            return
        command = AckermannDrive(steering_angle=float(steering), speed=float(speed))

        def publish_default(now_ns: int) -> None:
            bus.publish(default_topic, AckermannDriveStamped(Header.at(now_ns), command))

        scheduler.every(float(rate), publish_default, "zero_ackermann_cmd")

    def reset(self, seed: int = 0) -> None:
        """Both muxes as freshly started (the default command's timer is the scheduler's, re-based on reset)."""
        for mux in self.muxes:
            mux.reset()

    def in_control(self) -> str:
        """What drives the car: the final mux's input in control, or IDLE_ZERO when that input only carries the
        default zero command (which reaches the low-level mux through its Navigation input), or "idle"."""
        holder = self._final.holder
        if holder is None:
            return "idle"
        upstream = self._feeders.get(f"{self._final.namespace}/{holder.topic}")
        if upstream is not None:
            source = upstream.last_forwarded
            if source is not None and f"{upstream.namespace}/{source.topic}" == self.default_topic:
                return IDLE_ZERO
        return holder.name

    def _relay(
        self, source: str, target: str, to: ListenerAnswer[Callable[[Any], None] | None], msg: AckermannDriveStamped
    ) -> None:
        """topic_tools relay; a non-finite command is dropped here, naming the topic it was published on."""
        if msg is Forwarding.msg or accept_command(source, msg, self.warn):  # the first test: accept's own
            self.rows.forward(target, msg, to)
