"""servo_commands: turn the mux output (AckermannDriveStamped) into the six joint controller commands.

Profiles (profiles.yaml):
  ackermann  the seed: hinge angles from formula (2) and one speed per wheel so that no wheel slips,
             `speed` being the ground speed of base_link (the rear-axle centre).
  parallel   the original servo_commands.py: every wheel gets speed * wheel_rate_per_speed rad/s and both
             hinges get the same angle.
In both, a command faster than a wheel joint's velocity limit allows is slowed as a whole (every wheel rate scaled
by one factor), never clipped at one wheel.

The law itself is control/servo_law.py (shared with the batch of worlds, envs/batch_command.py); this node reads
the car's wheels and controller topics off its description and publishes the law's outputs per command. Where the
controllers alone take them, it hands them the values without messages; where a recorder takes them too, it hands the
recorder their rows besides (one hand-over, joining the command's own where the path handed it on as rows:
command_rows.py).
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable

from racecar_sim.bus import BusPort, ListenerAnswer
from racecar_sim.control.command_rows import Forwarding, float64_layout, joins_command_rows
from racecar_sim.control.controllers import ControllerConfig
from racecar_sim.control.mux import accept_command
from racecar_sim.control.servo_law import ServoLaw, ServoWheel
from racecar_sim.core.names import CarNames
from racecar_sim.core.throttle import ThrottledWarning
from racecar_sim.description.urdf import Robot
from racecar_sim.description.vehicle import VehicleGeometry
from racecar_sim.description.vehicle_params import VehicleParams
from racecar_sim.msgs import AckermannDriveStamped, Float64
from racecar_sim.nodes import NodeBase

log = logging.getLogger("racecar_sim.servo_commands")


class ServoCommands(NodeBase):
    """The servo_commands node for one profile."""

    def __init__(
        self,
        bus: BusPort,
        robot: Robot,
        controllers: ControllerConfig,
        mode: str,
        input_topic: str,
        wheel_rate_per_speed: float | None = None,
        now: Callable[[], int] = lambda: 0,
        names: CarNames = CarNames(),
        vehicle: VehicleParams | None = None,
    ) -> None:
        if mode not in ("ackermann", "parallel"):
            raise ValueError(f"servo mode '{mode}' is not ackermann or parallel")
        self.bus, self.mode = bus, mode
        self.geometry = VehicleGeometry.from_robot(robot)
        self.rate_per_speed = wheel_rate_per_speed or 1.0 / self.geometry.wheel_radius
        wheels, rate_topics, hinge_topics = [], [], {}
        for i, w in enumerate(self.geometry.wheels):
            limits = None
            if w.hinge_joint:
                hinge_topics[i] = names.topic(controllers.controller(w.hinge_joint).command_topic)
                joint = robot.joints[w.hinge_joint]
                if joint.type == "revolute" and joint.limit is not None:
                    limits = (joint.limit.lower, joint.limit.upper)
            wheel_limit = robot.joints[w.joint].limit
            rate_limit = wheel_limit.velocity if wheel_limit is not None and wheel_limit.velocity > 0 else None
            wheels.append(ServoWheel((w.centre[0], w.centre[1]), w.hinge_axis_point, limits, rate_limit))
            rate_topics.append(names.topic(controllers.controller(w.joint).command_topic))
        self.law = ServoLaw(
            mode,
            wheels,
            self.geometry.wheelbase,
            self.geometry.wheel_radius,
            self.rate_per_speed,
            _range(vehicle.s_min, vehicle.s_max) if vehicle else None,
            _range(vehicle.v_min, vehicle.v_max) if vehicle else None,
        )
        # the controller command topic of each of the law's outputs, in the order they are published
        self.topics = tuple(hinge_topics[i] if hinge else rate_topics[i] for i, hinge in self.law.outputs)
        self._warned = False
        # the last command's speed and steering_angle (the very float objects) and the law's values for them: a driver
        # that repeats one command object (a constant driver) gets them without the law's key being made again
        self._last_drive: tuple[object, object, list[float]] = (None, None, [])
        self.input_topic = input_topic
        self._takers = ListenerAnswer(self._find_takers)  # what takes each output's value straight
        self.warn = ThrottledWarning(log, now)
        bus.subscribe(input_topic, self._on_drive, AckermannDriveStamped)

    @property
    def max_curvature(self) -> float:
        """1/m, the tightest turn the hinge joints' limits allow (the ackermann law turns no tighter)."""
        return self.law.max_curvature

    @joins_command_rows
    def _on_drive(self, msg: AckermannDriveStamped) -> None:
        if not accept_command(self.input_topic, msg, self.warn):
            return
        drive = msg.drive
        speed, steer = drive.speed, drive.steering_angle
        last_speed, last_steer, values = self._last_drive
        if speed is not last_speed or steer is not last_steer:  # the same float objects: the same bits, sign included
            values = self._values(speed, steer)
            self._last_drive = (speed, steer, values)
        rows = Forwarding.rows if msg is Forwarding.msg else None  # the command's, handed on as rows by the path
        takers, recorded = self._takers(self.bus)
        if takers is not None:  # only the controllers (and a recorder) take these commands: their values, no Float64
            for take, value in zip(takers, values):
                take(value)
            if not recorded:
                self.bus.delivered(self.topics, Float64)
            elif rows is not None:
                rows.add(Float64, float64_layout(), self.topics, [(value,) for value in values])
            else:
                self.bus.publish_cdr_rows(Float64, float64_layout(), self.topics, [(value,) for value in values])
            return
        publish = self.bus.publish if rows is None else rows.publish  # after the command's rows gathered before
        for topic, value in zip(self.topics, values):
            publish(topic, Float64(value))

    def _find_takers(self) -> tuple[tuple[Callable[[float], None], ...] | None, bool]:
        """What takes each output's value where its topic's sole taker is a controller's command subscriber that takes
        values (ControllerCommands), and whether taps that take rows (a recorder) want them too: asked again only when
        the bus's listeners change; None where any other would take a message (a bridge, another subscriber, a tap
        taking objects: they get Float64 messages as before)."""
        for recorded in (False, True):
            found = [getattr(self.bus.sole_taker(topic, recorded), "take_value", None) for topic in self.topics]
            if all(found):
                return tuple(found), recorded  # type: ignore[arg-type]  # no None left in it
        return None, False

    def commands(self, speed: float, steer: float) -> list[tuple[str, float]]:
        """The controller commands for one drive command, (topic, rad or rad/s) in the order they are published."""
        return list(zip(self.topics, self._values(speed, steer)))

    def _values(self, speed: float, steer: float) -> list[float]:
        """The law's values for one drive command (warning once where a hinge would pass its limit)."""
        values, clamped = self.law.command(speed, steer)
        if clamped and not self._warned:
            self._warned = True
            log.warning(
                "servo_commands: steering_angle %.3f rad needs a hinge past its limit; "
                "turning as tight as the limits allow",
                steer,
            )
        return values


def _range(low: float | None, high: float | None) -> tuple[float, float] | None:
    """A vehicle set's (low, high) command limits; None where it gives neither."""
    if low is None and high is None:
        return None
    return (low if low is not None else -math.inf, high if high is not None else math.inf)
