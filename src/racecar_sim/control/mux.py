"""ackermann_cmd_mux and the mux.launch wiring of the original (original_stack.md §4.1).

A message is forwarded unchanged, at once, when no input holds control, when its input already holds
it, or when its input outranks the holder. Each input's timer restarts on every message; when the
holder's timer runs out, control is vacant ("idle") until some input sends again. The mux never
re-publishes on its own.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from functools import partial
from pathlib import Path

import yaml

from racecar_sim.bus import Bus
from racecar_sim.core.errors import ConfigError
from racecar_sim.core.time import to_ns
from racecar_sim.msgs import AckermannDrive, AckermannDriveStamped, Header, String
from racecar_sim.core.scheduler import Scheduler, Task

DATA = Path(__file__).parent / "data"


@dataclass(frozen=True)
class MuxInput:
    """One subscriber of the mux: name, topic relative to the mux, timeout (s) and priority."""

    name: str
    topic: str
    timeout: float
    priority: int


def load_mux_inputs(path: Path) -> tuple[list[MuxInput], str]:
    """Read a yocs-style mux YAML: the subscribers and the output topic name."""
    try:
        data = yaml.safe_load(path.read_text())
        inputs = [MuxInput(s["name"], s["topic"], float(s["timeout"]), int(s["priority"])) for s in data["subscribers"]]
        return inputs, data.get("publisher", "output")
    except (OSError, yaml.YAMLError, KeyError, TypeError, ValueError) as exc:
        raise ConfigError(f"{path}: malformed mux config: {' '.join(str(exc).split())}") from None


class AckermannCmdMux:
    """One ackermann_cmd_mux nodelet under `namespace` (e.g. /vesc/low_level/ackermann_cmd_mux)."""

    def __init__(self, bus: Bus, scheduler: Scheduler, now: Callable[[], int], namespace: str,
                 inputs: list[MuxInput], output: str = "output") -> None:
        self.bus, self.scheduler, self.now = bus, scheduler, now
        self.namespace = namespace
        self.output_topic = f"{namespace}/{output}"
        self.active_topic = f"{namespace}/active"
        self.holder: MuxInput | None = None
        self._timers: dict[str, Task] = {}
        bus.latch(self.active_topic)
        bus.publish(self.active_topic, String("idle"))
        for inp in inputs:
            bus.subscribe(f"{namespace}/{inp.topic}", partial(self._on_command, inp))

    def _on_command(self, inp: MuxInput, msg: AckermannDriveStamped) -> None:
        timer = self._timers.get(inp.name)
        if timer is not None:
            timer.cancel()
        self._timers[inp.name] = self.scheduler.at(self.now() + to_ns(inp.timeout), partial(self._on_timeout, inp),
                                                   f"{self.namespace} {inp.name} timeout")
        holder = self.holder
        if holder is None or holder is inp or inp.priority > holder.priority:
            if holder is not inp:
                self.holder = inp
                self.bus.publish(self.active_topic, String(inp.name))
            self.bus.publish(self.output_topic, msg)

    def _on_timeout(self, inp: MuxInput, _now: int) -> None:
        self._timers.pop(inp.name, None)
        if self.holder is inp:
            self.holder = None
            self.bus.publish(self.active_topic, String("idle"))


class CommandChain:
    """mux.launch: the high- and low-level muxes, the topic relays and the 6 Hz default zero command."""

    def __init__(self, bus: Bus, scheduler: Scheduler, now: Callable[[], int], config: Path = DATA / "mux.yaml") -> None:
        try:
            data = yaml.safe_load(config.read_text())
            self.output_topic: str = data["output"]
            default = data["default_command"]
            muxes, relays = data["muxes"], data["relays"]
        except (OSError, yaml.YAMLError, KeyError, TypeError) as exc:
            raise ConfigError(f"{config}: malformed mux wiring: {' '.join(str(exc).split())}") from None
        self.muxes = []
        for namespace, file in muxes.items():
            inputs, output = load_mux_inputs(config.parent / file)
            self.muxes.append(AckermannCmdMux(bus, scheduler, now, namespace, inputs, output))
        for source, target in relays:
            bus.subscribe(source, partial(bus.publish, target))
        command = AckermannDrive(steering_angle=float(default["steering_angle"]), speed=float(default["speed"]))

        def publish_default(now_ns: int) -> None:
            bus.publish(default["topic"], AckermannDriveStamped(Header.at(now_ns), command))

        scheduler.every(float(default["rate"]), publish_default, "zero_ackermann_cmd")
