"""gazebo_odometry.py: ground-truth odometry on /vesc/odom at 20 Hz, the map->odom TF, relay to /pf/pose/odom.

mode "original": frame map, child odom, world-frame twist, TF map->odom (what the original sim did).
mode "ros":      frame odom, child base_link, body-frame twist, TF odom->base_link (REP 105 convention).

The original reads the `racecar::base_link` entry of /gazebo/link_states; this node reads the same link state
from the MjData through CarState, the very calls /gazebo/link_states and /gazebo/model_states are filled from
(runtime/gazebo_api.py), so the poses are equal at equal stamps (tests/test_gazebo_api.py) and the odometry does
not depend on anyone listening to /gazebo/link_states.
"""

from __future__ import annotations

from functools import partial

import numpy as np

from racecar_sim.bus import BusPort, ListenerAnswer
from racecar_sim.core.errors import ConfigError
from racecar_sim.core.names import ODOM, ODOM_RELAY, TF, CarNames
from racecar_sim.core.time import NS_PER_S
from racecar_sim.msgs import (
    Header,
    Odometry,
    Point,
    Pose,
    PoseWithCovariance,
    Quaternion,
    TFMessage,
    Transform,
    TransformStamped,
    Twist,
    TwistWithCovariance,
    Vector3,
)
from racecar_sim.msgs.cdr_layout import CdrLayout
from racecar_sim.nodes import NodeBase, Timers
from racecar_sim.physics.state import CarState

FRAMES = {"original": ("map", "odom"), "ros": ("odom", "base_link")}


class OdometryPublisher(NodeBase):
    """The odometry node; `rate` 20 Hz as the original timer."""

    def __init__(
        self,
        bus: BusPort,
        scheduler: Timers,
        state: CarState,
        mode: str = "original",
        rate: float = 20.0,
        topic: str = ODOM,
        relay_topic: str | None = ODOM_RELAY,
        names: CarNames = CarNames(),
    ) -> None:
        if mode not in FRAMES:
            raise ConfigError(f"odometry mode {mode!r} is not one of {', '.join(FRAMES)}")
        self.bus, self.state, self.mode, self.topic = bus, state, mode, names.topic(topic)
        self.frame, self.child = (names.frame(f) for f in FRAMES[mode])
        self._tf_layout: CdrLayout | None = None  # the CDR layout of its /tf message (bytes for a recorder alone)
        self._local = mode == "ros"  # twist in the body frame
        self._tf_heard = ListenerAnswer(lambda: self.bus.has_listeners(TF))
        if relay_topic:
            relay = names.topic(relay_topic)
            bus.subscribe(self.topic, partial(bus.publish, relay))  # a relay: no Python frame of its own
        scheduler.every(rate, self.publish, "gazebo_odometry_node")

    def publish(self, now_ns: int) -> None:
        # Python floats, as the messages hold them
        px, py, pz, w, x, y, z, vx, vy, vz, wx, wy, wz = self.state.base_odometry(local=self._local)
        msg = Odometry(
            Header.at(now_ns, self.frame),
            self.child,
            PoseWithCovariance(Pose(Point(px, py, pz), Quaternion(x, y, z, w)), np.zeros(36)),
            TwistWithCovariance(Twist(Vector3(vx, vy, vz), Vector3(wx, wy, wz)), np.zeros(36)),
        )
        bus = self.bus
        bus.publish(self.topic, msg)
        if not self._tf_heard(bus):  # nobody would receive it: counted, not built
            bus.tally(TF, TFMessage)
            return
        cdr = bus.cdr_only(TF)
        if cdr and self._tf_layout is not None:  # only a recorder takes /tf: its bytes, packed from the numbers
            bus.publish_cdr(TF, TFMessage, self._tf_layout.pack((*divmod(now_ns, NS_PER_S), px, py, pz, x, y, z, w)))
            return
        tf = TFMessage(
            [
                TransformStamped(
                    Header.at(now_ns, self.frame), self.child, Transform(Vector3(px, py, pz), Quaternion(x, y, z, w))
                )
            ]
        )
        if cdr:  # its frames are every message's
            self._tf_layout = CdrLayout.read(tf)
        bus.publish(TF, tf)
