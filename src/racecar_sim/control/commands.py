"""The controller manager's command side: /racecar/<controller>/command (Float64) -> actuator setpoints."""

from __future__ import annotations

import logging
import math
from collections.abc import Callable

from racecar_sim.bus import BusPort, type_name
from racecar_sim.control.controllers import VELOCITY, ControllerConfig, JointController
from racecar_sim.core.names import CarNames
from racecar_sim.core.throttle import ThrottledWarning, is_finite_number
from racecar_sim.description.urdf import Robot
from racecar_sim.msgs import Float64
from racecar_sim.physics.state import CarState

log = logging.getLogger("racecar_sim.controller_manager")


class ControllerCommands:
    """Holds each controller's last command, as ros_control does, and writes it to the actuator."""

    def __init__(
        self,
        bus: BusPort,
        state: CarState,
        config: ControllerConfig,
        robot: Robot,
        now: Callable[[], int] = lambda: 0,
        names: CarNames = CarNames(),
    ) -> None:
        self.state = state
        self.warn = ThrottledWarning(log, now)
        self.limits: dict[str, tuple[float, float]] = {}
        for c in config.controllers:
            limit = robot.joints[c.joint].limit
            if c.type == VELOCITY and limit and limit.velocity > 0:
                # Gazebo zeroes effort that would push a joint past its velocity limit; asking for no more
                # than the limit has the same effect on a P controller.
                self.limits[c.name] = (-limit.velocity, limit.velocity)
            elif c.type != VELOCITY and robot.joints[c.joint].type == "revolute":
                assert limit is not None, "parse_urdf gives every revolute joint a <limit>"
                self.limits[c.name] = (limit.lower, limit.upper)  # JointPositionController enforces joint limits
            bus.subscribe(names.topic(c.command_topic), self._subscriber(c), Float64)

    def _subscriber(self, controller: JointController) -> Callable[[Float64], None]:
        """What takes one controller's commands: a closure over all it needs, as it runs six times per command."""
        name, topic, warn, set_command = controller.name, controller.command_topic, self.warn, self.state.set_command
        lo, hi = self.limits.get(name, _UNLIMITED)

        def take(value: float) -> None:
            # a finite float (what servo_commands sends) in one look; anything else through the full check
            if (type(value) is not float or value - value != 0.0) and not is_finite_number(value):
                warn(topic, "%s: ignored command %r (not a finite number)", topic, value)
                return
            if lo > value:  # min(max(value, lo), hi), without the calls
                value = lo
            if hi < value:
                value = hi
            set_command(name, value)

        def on_command(msg: Float64) -> None:
            if type(msg) is not Float64:
                warn(
                    f"{topic} type",
                    "%s: ignored a %s message (the topic takes %s)",
                    topic,
                    type_name(msg),
                    type_name(Float64),
                )
                return
            take(msg.data)

        # what a publisher whose message only this takes (Bus.sole_taker) may hand the command to: its value
        on_command.take_value = take  # type: ignore[attr-defined]
        return on_command


_UNLIMITED = (-math.inf, math.inf)
