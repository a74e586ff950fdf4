"""gazebo_odometry.py: ground-truth odometry on /vesc/odom at 20 Hz, the map->odom TF, relay to /pf/pose/odom.

mode "original": frame map, child odom, world-frame twist, TF map->odom (what the original sim did).
mode "ros":      frame odom, child base_link, body-frame twist, TF odom->base_link (REP 105 convention).

The original reads the `racecar::base_link` entry of /gazebo/link_states; this node reads the same link state
from the MjData through CarState, the very calls /gazebo/link_states and /gazebo/model_states are filled from
(runtime/gazebo_api.py), so the poses are equal at equal stamps (tests/test_gazebo_api.py) and the odometry does
not depend on anyone listening to /gazebo/link_states.
"""

from __future__ import annotations

import numpy as np

from racecar_sim.bus import Bus
from racecar_sim.core.errors import ConfigError
from racecar_sim.core.names import ODOM, ODOM_RELAY, TF, CarNames
from racecar_sim.msgs import (Header, Odometry, Point, Pose, PoseWithCovariance, Quaternion, TFMessage, Twist,
                              TwistWithCovariance, Vector3)
from racecar_sim.physics.state import CarState
from racecar_sim.core.scheduler import Scheduler
from racecar_sim.sensors.robot_state import transform_msg

FRAMES = {"original": ("map", "odom"), "ros": ("odom", "base_link")}


class OdometryPublisher:
    """The odometry node; `rate` 20 Hz as the original timer."""

    def __init__(self, bus: Bus, scheduler: Scheduler, state: CarState, mode: str = "original", rate: float = 20.0,
                 topic: str = ODOM, relay_topic: str | None = ODOM_RELAY, names: CarNames = CarNames()) -> None:
        if mode not in FRAMES:
            raise ConfigError(f"odometry mode {mode!r} is not one of {', '.join(FRAMES)}")
        self.bus, self.state, self.mode, self.topic = bus, state, mode, names.topic(topic)
        self.frame, self.child = (names.frame(f) for f in FRAMES[mode])
        if relay_topic:
            relay = names.topic(relay_topic)
            bus.subscribe(self.topic, lambda msg: bus.publish(relay, msg))
        scheduler.every(rate, self.publish, "gazebo_odometry_node")

    def publish(self, now_ns: int) -> None:
        pos, quat = self.state.base_pose()
        linear, angular = self.state.base_velocity(local=self.mode == "ros")
        w, x, y, z = (float(v) for v in quat)
        msg = Odometry(
            Header.at(now_ns, self.frame), self.child,
            PoseWithCovariance(Pose(Point(*(float(v) for v in pos)), Quaternion(x, y, z, w)), np.zeros(36)),
            TwistWithCovariance(Twist(Vector3(*(float(v) for v in linear)), Vector3(*(float(v) for v in angular))),
                                np.zeros(36)),
        )
        self.bus.publish(self.topic, msg)
        self.bus.publish(TF, TFMessage([transform_msg(now_ns, self.frame, self.child, pos, quat)]))
