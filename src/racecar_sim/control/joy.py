"""joy_node as a node: a gamepad's axes and buttons as sensor_msgs/Joy, with ROS joy_node's conventions.

The original car runs `joy/joy_node` inside `<group ns="vesc">` (racecar-v2-teleop.launch.xml), so it publishes
/vesc/joy, with the parameters of racecar/config/racecar-v2/joy_teleop.yaml (deadzone 0.01, autorepeat_rate 20,
coalesce_interval 0.01). What joy_node does with them, and what this node does on sim time:

* an axis is the Linux joystick value v (the driver's whole number, -32768 to 32767, over 32767; stick up and stick
  left negative) negated and rescaled past the dead zone: 0 within +-deadzone, else -(v -+ deadzone) / (1 -
  deadzone), so stick up and stick left are positive and the rest of the range still reaches +-1; an axis reads 0
  until it first moves (joy_node drops the device's initial axis events); a hat is two more axes after the others
  (x, then y: left and up positive), as the Linux joystick driver reports hats;
* buttons are 0 or 1, their state at opening included;
* a button event publishes at once, axis events at the end of the coalesce interval (this node looks at the device
  every coalesce_interval s of sim time, at most once per physics step, and publishes when anything changed); with
  nothing happening, the last state is published again every 1/autorepeat_rate s;
* nothing is published while no device is open; a device that goes away stops the publishing until it comes back
  (the teleop input then times out in the mux, and the car stops).

The device is anything with `read()` returning what happened since the last call (control/joy_device.py reads a
gamepad through pygame's SDL2 joystick); `JoyState` is the conversion, usable on its own.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np

from racecar_sim.bus import BusPort
from racecar_sim.core.errors import ConfigError
from racecar_sim.core.tables import finite_number
from racecar_sim.core.time import NS_PER_S
from racecar_sim.msgs import Header, Joy
from racecar_sim.nodes import NodeBase, Timers

log = logging.getLogger("racecar_sim.joy")
JOY = "/vesc/joy"


@dataclass(frozen=True)
class JoyNodeConfig:
    """joy_node's parameters (`~deadzone`, `~autorepeat_rate`, `~coalesce_interval`, `~dev`, `~dev_name`), with
    joy_node's own defaults."""

    deadzone: float = 0.05
    autorepeat_rate: float = 0.0  # Hz; 0: publish only on events
    coalesce_interval: float = 0.001  # s
    dev: str = "/dev/input/js0"
    dev_name: str = ""

    @classmethod
    def from_params(cls, params: Mapping[str, Any], where: str) -> JoyNodeConfig:
        """The node's private parameters, checked and clamped as joy_node does (each clamp a warning); a value that
        is not a number is a ConfigError naming `where` and the parameter."""
        known = ("deadzone", "autorepeat_rate", "coalesce_interval")
        values = {k: finite_number(params[k], f"{where}: ~{k}") for k in known if params.get(k) is not None}
        deadzone = values.get("deadzone", cls.deadzone)
        if deadzone >= 1:
            log.warning(
                "%s: ~deadzone %g is >= 1: taken as %g (joy_node divides it by 32767)",
                where,
                deadzone,
                deadzone / 32767,
            )
            deadzone /= 32767
        if deadzone > 0.9:
            log.warning("%s: ~deadzone %g greater than 0.9, set to 0.9", where, deadzone)
            deadzone = 0.9
        if deadzone < 0:
            log.warning("%s: ~deadzone %g less than 0, set to 0", where, deadzone)
            deadzone = 0.0
        rate = values.get("autorepeat_rate", cls.autorepeat_rate)
        if rate < 0:
            log.warning("%s: ~autorepeat_rate %g less than 0, set to 0", where, rate)
            rate = 0.0
        interval = values.get("coalesce_interval", cls.coalesce_interval)
        if interval < 0:
            log.warning("%s: ~coalesce_interval %g less than 0, set to 0", where, interval)
            interval = 0.0
        text = {k: params[k] for k in ("dev", "dev_name") if params.get(k) is not None}
        for key, value in text.items():
            if not isinstance(value, str):
                raise ConfigError(f"{where}: ~{key}: expected a string, got {value!r}")
        return cls(deadzone, rate, interval, str(text.get("dev", cls.dev)), str(text.get("dev_name", cls.dev_name)))


def joy_axis(value: float, deadzone: float) -> float:
    """joy_node's axis from the device's value (the driver's -32768..32767 over 32767, Linux's sign: stick up and stick
    left negative)."""
    if value > deadzone:
        return -(value - deadzone) / (1.0 - deadzone)
    if value < -deadzone:
        return -(value + deadzone) / (1.0 - deadzone)
    return 0.0


# What a device's read() returns, in order: ("opened", name, axes, buttons, hats, pressed buttons), ("closed",),
# ("axis", index, raw / 32767), ("button", index, pressed), ("hat", index, (x, y): x -1 left, y +1 up).
DeviceEvent = tuple[Any, ...]


class JoyDevice(Protocol):
    """A joystick as the node reads it."""

    def read(self) -> list[DeviceEvent]: ...

    def close(self) -> None: ...


class JoyState:
    """The axes and buttons joy_node publishes for one open device."""

    def __init__(self, deadzone: float, axes: int, buttons: int, hats: int = 0, pressed: Sequence[int] = ()) -> None:
        self.deadzone, self.first_hat_axis = deadzone, axes
        self.axes = np.zeros(axes + 2 * hats, dtype=np.float32)
        self.buttons = np.zeros(buttons, dtype=np.int32)
        for index in pressed:
            self.button(index, True)

    def axis(self, index: int, value: float) -> None:
        self._grow_axes(index)
        self.axes[index] = joy_axis(float(value), self.deadzone)

    def button(self, index: int, pressed: bool) -> None:
        if index >= len(self.buttons):
            self.buttons = np.concatenate([self.buttons, np.zeros(index + 1 - len(self.buttons), np.int32)])
        self.buttons[index] = 1 if pressed else 0

    def hat(self, index: int, x: float, y: float) -> None:
        """A hat's two axes: the Linux driver's HAT0X (-1 left) and HAT0Y (-1 up), negated by joy_node."""
        base = self.first_hat_axis + 2 * index
        self._grow_axes(base + 1)
        self.axes[base] = -float(np.sign(x))
        self.axes[base + 1] = float(np.sign(y))

    def apply(self, event: DeviceEvent) -> None:
        """One axis, button or hat event of a device's read()."""
        kind = event[0]
        if kind == "axis":
            self.axis(int(event[1]), float(event[2]))
        elif kind == "button":
            self.button(int(event[1]), bool(event[2]))
        elif kind == "hat":
            x, y = event[2]
            self.hat(int(event[1]), x, y)

    def message(self, stamp_ns: int) -> Joy:
        return Joy(Header.at(stamp_ns), self.axes.copy(), self.buttons.copy())

    def _grow_axes(self, index: int) -> None:
        if index >= len(self.axes):
            self.axes = np.concatenate([self.axes, np.zeros(index + 1 - len(self.axes), np.float32)])


class JoyNode(NodeBase):
    """Reads `device` every coalesce interval of sim time and publishes sensor_msgs/Joy on `topic` (/vesc/joy)."""

    def __init__(
        self,
        bus: BusPort,
        timers: Timers,
        now: Callable[[], int],
        device: JoyDevice,
        config: JoyNodeConfig | None = None,
        topic: str = JOY,
    ) -> None:
        self.bus, self.now, self.device, self.topic = bus, now, device, topic
        self.config = config or JoyNodeConfig()
        self.state: JoyState | None = None
        self.device_name: str | None = None
        self.published = 0
        self._last_ns: int | None = None
        self._repeat_ns = round(NS_PER_S / self.config.autorepeat_rate) if self.config.autorepeat_rate > 0 else None
        period_ns = max(round(self.config.coalesce_interval * NS_PER_S), timers.step_ns)
        self._timer = timers.every(NS_PER_S / period_ns, self._poll, "joy_node")

    @property
    def connected(self) -> bool:
        return self.state is not None

    def _poll(self, now_ns: int) -> None:
        changed = False
        for event in self.device.read():
            if event[0] == "opened":
                _, self.device_name, axes, buttons, hats, pressed = event
                self.state = JoyState(self.config.deadzone, axes, buttons, hats, pressed)
                log.info("opened joystick %s (deadzone %g)", self.device_name, self.config.deadzone)
                changed = True
            elif event[0] == "closed":
                if self.state is not None:
                    log.warning("joystick %s went away: no %s until it is back", self.device_name, self.topic)
                self.state, self._last_ns = None, None
            elif self.state is not None:
                self.state.apply(event)
                changed = True
        if self.state is None:
            return
        due = self._repeat_ns is not None and (self._last_ns is None or now_ns - self._last_ns >= self._repeat_ns)
        if changed or due:
            self._last_ns = now_ns
            self.published += 1
            self.bus.publish(self.topic, self.state.message(now_ns))

    def reset(self, seed: int) -> None:
        self._last_ns = None  # sim time went back: repeat from the next look

    def close(self) -> None:
        """Stop reading the device, and close it (again: nothing)."""
        self._timer.cancel()
        self.device.close()
        self.state = None
