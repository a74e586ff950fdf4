"""Every name of a car - topics, TF frames, MuJoCo names, its Gazebo model name - derived from its namespace.

One car without a namespace has the original names (`/scan`, `/vesc/odom`, frame `base_link`, Gazebo model
`racecar`). A car with namespace `car2` gets what `<group ns="car2">` plus `tf_prefix` give in ROS 1: its topics
under `/car2` (`/car2/scan`, `/car2/vesc/odom`, `/car2/racecar/joint_states`), its frames `car2/base_link`, its
MuJoCo bodies, geoms, joints, actuators, sites and cameras `car2/<name>`, and the Gazebo model `car2`.
Topics that belong to the whole simulation (`/tf`, `/tf_static`, `/clock`, `/gazebo/...`) and the world frame
`map` are shared by every car.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from racecar_sim.core.errors import ConfigError

TF = "/tf"
TF_STATIC = "/tf_static"
CLOCK = "/clock"
WORLD_FRAME = "map"  # gazebo_odometry's fixed frame; shared by all cars
GLOBAL_TOPICS = (TF, TF_STATIC, CLOCK)
DEFAULT_MODEL = "racecar"  # racecar.launch: spawn_model -model racecar
_NAMESPACE = re.compile(r"[A-Za-z][A-Za-z0-9_]*")

# The original stack's car-relative names (original_stack.md §4.5)
ODOM = "/vesc/odom"
ODOM_RELAY = "/pf/pose/odom"
NAVIGATION = "/vesc/ackermann_cmd_mux/input/navigation"
TELEOP = "/vesc/ackermann_cmd_mux/input/teleop"
SAFETY = "/vesc/ackermann_cmd_mux/input/safety"
ROBOT_DESCRIPTION = "/robot_description"  # the URDF, as ROS 2's robot_state_publisher publishes it (latched)
BASE_LINK = "base_link"


@dataclass(frozen=True)
class CarNames:
    """The names of one car. `namespace` "" keeps the original names."""

    namespace: str = ""

    def __post_init__(self) -> None:
        if self.namespace and not _NAMESPACE.fullmatch(self.namespace):
            raise ConfigError(
                f"car name {self.namespace!r} must start with a letter and hold only letters, digits "
                "and _ (it becomes a ROS namespace and a TF prefix)"
            )

    @property
    def model(self) -> str:
        """The Gazebo model name: `racecar` for the unnamed car (as spawn_model named it), else the namespace."""
        return self.namespace or DEFAULT_MODEL

    def topic(self, name: str) -> str:
        """A car's topic: `/scan` -> `/car2/scan`; the simulation's own topics (`/tf`, `/clock`) stay as they are."""
        if not self.namespace or name in GLOBAL_TOPICS or name.startswith("/gazebo/"):
            return name
        return f"/{self.namespace}/{name.lstrip('/')}"

    def frame(self, name: str) -> str:
        """A TF frame with the car's tf_prefix: `base_link` -> `car2/base_link`; the world frame stays `map`."""
        if not self.namespace or not name or name == WORLD_FRAME:
            return name
        return f"{self.namespace}/{name}"

    def mj(self, name: str) -> str:
        """A MuJoCo element name (body, geom, joint, actuator, site, camera) of this car."""
        return f"{self.namespace}/{name}" if self.namespace else name

    def local(self, mj_name: str) -> str | None:
        """The car-relative name of a MuJoCo element of this car, or None if it is not this car's."""
        if not self.namespace:
            return mj_name
        prefix = f"{self.namespace}/"
        return mj_name[len(prefix) :] if mj_name.startswith(prefix) else None

    @property
    def noise_prefix(self) -> str:
        """Key of this car's noise streams: the unnamed car keeps the original streams (bit-identical runs)."""
        return f"{self.namespace}/" if self.namespace else ""
