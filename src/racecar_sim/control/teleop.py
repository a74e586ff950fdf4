"""keyboard_teleop.py as a node: keys to AckermannDriveStamped on the mux's teleop input."""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from racecar_sim.bus import BusPort
from racecar_sim.core.errors import ConfigError
from racecar_sim.core.tables import finite_number, load_record
from racecar_sim.core.time import to_ns
from racecar_sim.msgs import AckermannDrive, AckermannDriveStamped, Header
from racecar_sim.nodes import Timers

TELEOP = "/vesc/ackermann_cmd_mux/input/teleop"
DEFAULTS = Path(__file__).parent / "data" / "keyboard_teleop.yaml"


@dataclass(frozen=True)
class TeleopConfig:
    """Key bindings and magnitudes (keyboard_teleop.yaml)."""

    speed: float
    turn: float
    bindings: dict[str, tuple[float, float]]
    hold: float
    repeat_rate: float
    acceleration: float
    jerk: float
    steering_angle_velocity: float


def load_teleop_config(path: Path = DEFAULTS) -> TeleopConfig:
    """Read a keyboard_teleop.yaml; ConfigError names the file and the field."""
    path = Path(path)
    config = load_record(path, TeleopConfig)
    bindings: dict[str, tuple[float, float]] = {}
    for key, factors in (config.bindings or {}).items():
        if not isinstance(factors, (list, tuple)) or len(factors) != 2:
            raise ConfigError(f"{path}: bindings: {key}: expected [speed factor, steering factor], got {factors!r}")
        speed, steering = (finite_number(f, f"{path}: bindings: {key}") for f in factors)
        bindings[str(key)] = (speed, steering)
    if config.hold < 0 or config.repeat_rate <= 0:
        raise ConfigError(
            f"{path}: hold must be >= 0 and repeat_rate positive, got {config.hold:g}, {config.repeat_rate:g}"
        )
    return dataclasses.replace(config, bindings=bindings)


class KeyboardTeleop:
    """Turns key presses into drive commands on /vesc/ackermann_cmd_mux/input/teleop.

    `w` forward, `a`/`d` forward and steer left/right, `s` reverse, any other key stops. Each key
    event publishes at once and then repeats for `hold` s, so a held key drives smoothly through the
    keyboard's auto-repeat delay; releasing it stops the car `hold` + 0.2 s (the mux timeout) later.
    """

    def __init__(
        self,
        bus: BusPort,
        scheduler: Timers,
        now: Callable[[], int],
        speed: float | None = None,
        turn: float | None = None,
        hold: float | None = None,
        config: TeleopConfig | None = None,
        topic: str = TELEOP,
    ) -> None:
        self.config = config or load_teleop_config()
        self.bus, self.now, self.topic = bus, now, topic
        self.speed = self.config.speed if speed is None else speed
        self.turn = self.config.turn if turn is None else turn
        self.hold_ns = to_ns(self.config.hold if hold is None else hold)
        self.drive = AckermannDrive()
        self.last_key: str | None = None
        self._hold_until = -1
        scheduler.every(self.config.repeat_rate, self._repeat, "keyboard_teleop")

    def key(self, ch: str) -> None:
        """One key event (a press or an auto-repeat)."""
        speed_factor, steer_factor = self.config.bindings.get(ch.lower(), (0.0, 0.0))
        self.last_key = ch
        self.drive = AckermannDrive(
            steering_angle=steer_factor * self.turn,
            speed=speed_factor * self.speed,
            acceleration=self.config.acceleration,
            jerk=self.config.jerk,
            steering_angle_velocity=self.config.steering_angle_velocity,
        )
        self._hold_until = self.now() + self.hold_ns
        self._publish(self.now())

    def stop(self) -> None:
        """The final zero command of the original's shutdown; no repeats after it."""
        self.key("")
        self._hold_until = -1

    @property
    def active(self) -> bool:
        """Whether a key event is still being repeated."""
        return self.now() < self._hold_until

    def _repeat(self, now_ns: int) -> None:
        if now_ns < self._hold_until:
            self._publish(now_ns)

    def _publish(self, now_ns: int) -> None:
        self.bus.publish(self.topic, AckermannDriveStamped(Header.at(now_ns, "base_link"), self.drive))
