"""racecar_control.yaml: the ros_control joint controllers of a car, read and checked against its description.

What the YAML says (controller types, joints, PID gains, the joint-state rate) as plain data; control/controllers.py
realises it as MuJoCo actuators, control/ros_control.py as the nodes gazebo_ros_control starts.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import yaml

from racecar_sim.core import yaml_text
from racecar_sim.core.errors import ConfigError, DescriptionError
from racecar_sim.core.tables import finite_number
from racecar_sim.description.urdf import Robot
from racecar_sim.description.vehicle import VehicleGeometry

VELOCITY = "effort_controllers/JointVelocityController"
POSITION = "effort_controllers/JointPositionController"
JOINT_STATE = "joint_state_controller/JointStateController"
STEERING_HINGES = ("left_steering_hinge_joint", "right_steering_hinge_joint")  # racecar_control.yaml's
_EFFORT_INTERFACES = {"EffortJointInterface", "hardware_interface/EffortJointInterface"}


@dataclass(frozen=True)
class Gains:
    """PID gains of one controller (ros_control's `pid` block)."""

    p: float
    i: float = 0.0
    d: float = 0.0
    i_clamp: float = 0.0


@dataclass(frozen=True)
class JointController:
    """One effort controller: its name (= its command topic's namespace), type, joint and gains."""

    name: str
    type: str
    joint: str
    gains: Gains

    @property
    def command_topic(self) -> str:
        return f"{self.namespace}/{self.name}/command"

    namespace: str = "/racecar"


@dataclass(frozen=True)
class ControllerConfig:
    """Everything racecar_control.yaml says: the joint controllers and the joint-state publish rate."""

    namespace: str
    controllers: tuple[JointController, ...]
    joint_state_rate: float

    def controller(self, joint: str) -> JointController:
        return next(c for c in self.controllers if c.joint == joint)


def load_controller_config(path: str | Path, robot: Robot) -> ControllerConfig:
    """Parse and check a ros_control YAML against the robot's joints and transmissions."""
    path = Path(path)
    try:
        data = yaml_text.safe_load(path.read_text())
    except (OSError, yaml.YAMLError) as exc:
        raise ConfigError(f"{path}: cannot read controller config: {' '.join(str(exc).split())}") from None
    if not isinstance(data, dict) or len(data) != 1:
        raise ConfigError(f"{path}: expected one top-level namespace (e.g. 'racecar:')")
    namespace, entries = next(iter(data.items()))
    if not isinstance(entries, dict):
        raise ConfigError(f"{path}: {namespace}: expected a mapping of controller names to their parameters")
    effort_joints = {t.joint for t in robot.transmissions if t.hardware_interface in _EFFORT_INTERFACES}
    description = robot.source or f"of robot '{robot.name}'"
    controllers, rate = [], 0.0
    for name, entry in entries.items():
        where = f"{path}: {namespace}/{name}"
        if not isinstance(entry, dict):
            raise ConfigError(f"{where}: expected a mapping with type, joint and pid")
        kind = entry.get("type")
        if kind == JOINT_STATE:
            rate = finite_number(entry.get("publish_rate", 50), f"{where}/publish_rate")
            if rate <= 0:
                raise ConfigError(f"{where}/publish_rate: must be positive, got {rate:g}")
            continue
        if kind not in (VELOCITY, POSITION):
            raise ConfigError(f"{where}: controller type '{kind}' is not supported")
        joint = entry.get("joint")
        if joint not in robot.joints:
            raise ConfigError(
                f"{where}: joint '{joint}' is not in the robot description {description}: add the "
                "joint to the xacro, or drop the controller"
            )
        if joint not in effort_joints:
            raise ConfigError(
                f"{where}: joint '{joint}' has no <transmission> with an EffortJointInterface in "
                f"{description}: add one for it to the xacro"
            )
        pid = entry.get("pid") or {}
        if not isinstance(pid, dict):
            raise ConfigError(f"{where}/pid: expected a mapping of gains (p, i, d, i_clamp), got {pid!r}")
        gains = Gains(*(_gain(pid, k, f"{where}/pid/{k}") for k in ("p", "i", "d", "i_clamp")))
        if kind == VELOCITY and gains.d != 0.0:
            raise ConfigError(
                f"{where}: a d gain on a JointVelocityController (acceleration feedback) is not supported"
            )
        controllers.append(JointController(name, kind, joint, gains, f"/{namespace}"))
    _check_drivable(path, robot, controllers, description)
    return ControllerConfig(f"/{namespace}", tuple(controllers), rate)


def _check_drivable(path: Path, robot: Robot, controllers: list[JointController], description: str) -> None:
    """servo_commands drives four wheels and steers two hinges, each through a controller of the YAML: a
    description without them is refused here, with one line, rather than deep inside the first run."""
    try:
        geometry = VehicleGeometry.from_robot(robot)
    except DescriptionError as exc:
        hinges = [c.joint for c in controllers if c.type == POSITION] or list(STEERING_HINGES)
        raise DescriptionError(
            f"{description}: servo_commands cannot drive it ({exc}): it needs the steering hinge "
            f"joints {' and '.join(hinges)} (as {path.name} expects), each carrying a front wheel, "
            "and two rear wheels"
        ) from None
    driven = {c.joint for c in controllers}
    for wheel in geometry.wheels:
        for joint, kind in ((wheel.joint, VELOCITY), (wheel.hinge_joint, POSITION)):
            if joint is not None and joint not in driven:
                raise ConfigError(
                    f"{path}: no controller for joint '{joint}' of {description} (servo_commands "
                    f"commands every wheel and steering hinge): add a {kind} for it"
                )


def _gain(pid: dict, key: str, where: str) -> float:
    """A ros_control gain: a finite number >= 0 (a negative gain pushes away from the set point)."""
    value = finite_number(pid.get(key, 0.0), where)
    if value < 0:
        raise ConfigError(f"{where}: must not be negative, got {value:g}")
    return value
