"""A gamepad read through pygame's SDL2 joystick (the `joy` extra: pygame-ce), as JoyNode's device.

pygame is imported only here, and only when a gamepad is asked for. SDL is started with its joystick and event
subsystems and the `dummy` video driver (the event queue needs a video subsystem; no window is opened, so it runs
headless and over SSH), HIDAPI off (SDL then reads every gamepad through the kernel's evdev, numbering axes and
buttons in the order the Linux joystick driver behind ROS joy_node does), background events on. A variable the
user set keeps the user's value.

Choosing a device, as `--joy DEVICE` or joy_node's `~dev` / `~dev_name`: nothing (the first gamepad), an index
(`0`, `1`), a Linux joystick path (`/dev/input/js1`: its number as the index, a best guess: SDL numbers devices in
the order it finds them), or a name (exact, else a case-insensitive part of it, e.g. `F710`).
"""

from __future__ import annotations

import contextlib
import os
import re
from collections.abc import Iterator
from types import ModuleType
from typing import Any

from racecar_sim.control.joy import DeviceEvent
from racecar_sim.core.errors import ConfigError

INSTALL = "pip install 'racecar-sim[joy]'"
SDL_HINTS = {
    "PYGAME_HIDE_SUPPORT_PROMPT": "1",
    "SDL_VIDEODRIVER": "dummy",
    "SDL_JOYSTICK_HIDAPI": "0",
    "SDL_JOYSTICK_ALLOW_BACKGROUND_EVENTS": "1",
}
_JS_PATH = re.compile(r"^/dev/input/js(\d+)$")


class GamepadUnavailable(ConfigError):
    """No gamepad can be read: pygame is not installed, SDL cannot start, or no device matches."""


@contextlib.contextmanager
def _hints() -> Iterator[None]:
    """SDL's hints as environment variables while SDL starts (a user's own setting wins); restored after."""
    added = [name for name in SDL_HINTS if name not in os.environ]
    os.environ.update({name: SDL_HINTS[name] for name in added})
    try:
        yield
    finally:
        for name in added:
            os.environ.pop(name, None)


def start_sdl() -> ModuleType:
    """pygame with SDL's joystick subsystem and event queue running; GamepadUnavailable if it cannot be."""
    with _hints():
        try:
            import pygame
        except ImportError:
            raise GamepadUnavailable(f"reading a gamepad needs pygame-ce, which is not installed: {INSTALL}") from None
        try:
            if not pygame.display.get_init():
                pygame.display.init()
            pygame.joystick.init()
        except pygame.error as exc:
            raise GamepadUnavailable(f"SDL cannot start its joystick subsystem: {exc}") from None
    return pygame


def _names(pygame: ModuleType) -> list[str]:
    return [pygame.joystick.Joystick(i).get_name() for i in range(pygame.joystick.get_count())]


def pick_device(selector: str | None, names: list[str]) -> int | None:
    """The index of the device `selector` names among `names` (None: no such device)."""
    if not names:
        return None
    if selector is None or selector == "":
        return 0
    text = selector.strip()
    match = _JS_PATH.match(text)
    if text.isdigit() or match:
        index = int(match.group(1) if match else text)
        return index if index < len(names) else None
    if text in names:
        return names.index(text)
    found = [i for i, name in enumerate(names) if text.lower() in name.lower()]
    return found[0] if found else None


def describe(names: list[str]) -> str:
    return ", ".join(f"{i}: {name}" for i, name in enumerate(names)) or "none"


class Gamepad:
    """One SDL joystick; `read()` gives what happened since the last call, as JoyNode takes it.

    joystick: a pygame Joystick (anything with get_instance_id, get_name, get_numaxes, get_numbuttons, get_numhats,
    get_button and get_axis). If it goes away, the first gamepad of the same name (or, chosen by index, at the same
    index) that SDL adds later is opened in its place."""

    def __init__(self, joystick: Any, selector: str | None = None, pygame: ModuleType | None = None) -> None:
        self.pygame = pygame or start_sdl()
        # the driver's axis value is a whole number from -32768 to 32767: pygame-ce divides it by 32768, pygame by
        # 32767; joy_node by 32767, so that +-32767 is +-1 (and -32768 a hair past -1)
        self._raw_scale = 32768.0 if getattr(self.pygame, "IS_CE", False) else 32767.0
        self.selector = selector
        self.joystick: Any = None
        self.name = ""
        self._events: list[DeviceEvent] = []
        self._queue: list[Any] = []  # pygame events taken off SDL's one queue for this gamepad
        self._open(joystick)
        _READERS.append(self)

    def _open(self, joystick: Any) -> None:
        self.joystick = joystick
        self.instance_id = joystick.get_instance_id()
        self.name = joystick.get_name()
        buttons, axes = joystick.get_numbuttons(), joystick.get_numaxes()
        pressed = [i for i in range(buttons) if joystick.get_button(i)]
        # joy_node drops the initial axis events: an axis reads 0 until it moves from where it was at opening
        self._resting = {i: self._axis_value(joystick.get_axis(i)) for i in range(axes)}
        self._events.append(("opened", self.name, axes, buttons, joystick.get_numhats(), pressed))

    def _axis_value(self, value: float) -> float:
        """pygame's axis value as joy_node sees the driver's: the whole number over 32767."""
        raw = max(-32768, min(32767, round(float(value) * self._raw_scale)))
        return raw / 32767.0

    @property
    def connected(self) -> bool:
        return self.joystick is not None

    def read(self) -> list[DeviceEvent]:
        pg = self.pygame
        _share_events(pg)
        events, self._events = self._events, []
        queue, self._queue = self._queue, []
        for event in queue:
            if event.type == pg.JOYDEVICEADDED:
                if self.joystick is None:
                    self._reopen(event.device_index)
                    events, self._events = events + self._events, []
                continue
            if getattr(event, "instance_id", None) != self.instance_id or self.joystick is None:
                continue
            if event.type == pg.JOYAXISMOTION:
                value = self._axis_value(event.value)
                if self._resting.get(event.axis) == value:
                    continue
                self._resting.pop(event.axis, None)
                events.append(("axis", event.axis, value))
            elif event.type in (pg.JOYBUTTONDOWN, pg.JOYBUTTONUP):
                events.append(("button", event.button, event.type == pg.JOYBUTTONDOWN))
            elif event.type == pg.JOYHATMOTION:
                events.append(("hat", event.hat, tuple(event.value)))
            elif event.type == pg.JOYDEVICEREMOVED:
                events.append(("closed",))
                self.joystick = None
        return events

    def _reopen(self, device_index: int) -> None:
        try:
            candidate = self.pygame.joystick.Joystick(device_index)
        except self.pygame.error:
            return
        text = (self.selector or "").strip()
        by_index = not text or text.isdigit() or _JS_PATH.match(text) is not None
        wanted = pick_device(self.selector, _names(self.pygame)) if by_index else None
        if candidate.get_name() == self.name or (by_index and wanted == device_index):
            self._open(candidate)

    def close(self) -> None:
        if self.joystick is not None:
            with contextlib.suppress(Exception):
                self.joystick.quit()
            self.joystick = None
        if self in _READERS:
            _READERS.remove(self)


_READERS: list[Gamepad] = []  # the gamepads open in this process (a fleet's cars may each have one)


def _share_events(pygame: ModuleType) -> None:
    """Take SDL's events (one queue for the process) and hand each open gamepad its own share: its device's
    events, and every device added."""
    for event in pygame.event.get():
        for reader in _READERS:
            if event.type == pygame.JOYDEVICEADDED or getattr(event, "instance_id", None) == reader.instance_id:
                reader._queue.append(event)


def open_gamepad(selector: str | None = None, fallback: str | None = None) -> Gamepad:
    """The gamepad `selector` names (the first one if None); `fallback` is tried when it names none (joy_node's
    `~dev` after `~dev_name`). GamepadUnavailable says what was found."""
    pygame = start_sdl()
    names = _names(pygame)
    if not names:
        raise GamepadUnavailable("no gamepad found (SDL sees no joystick): plug one in, or check its permissions")
    index = pick_device(selector, names)
    chosen = selector
    if index is None and fallback is not None:
        index, chosen = pick_device(fallback, names), fallback
    if index is None:
        raise GamepadUnavailable(f"no gamepad matches '{selector}' (found {describe(names)})")
    return Gamepad(pygame.joystick.Joystick(index), chosen, pygame)
