"""f1tenth_gym_ros's names for the sim's cars: the topic map of `--topic-map f1tenth`.

f1tenth_gym_ros (config/sim.yaml, f1tenth_gym_ros/gym_bridge.py) names the first car `ego_racecar` and each other
one an opponent, `opp_racecar`, `opp_racecar2`, `opp_racecar3`, ... (the opp_* names with the opponent's number
appended from the second on). Per car:

  sim topic (car1 / unnamed car)             F1TENTH name        type
  /scan (the lidar's topic)                  /scan | /opp_scan, /opp_scan2 ...       sensor_msgs/LaserScan
  /vesc/odom                                 /ego_racecar/odom | /opp_racecar/odom, /opp_racecar2/odom ...
  /vesc/ackermann_cmd_mux/input/navigation   /drive | /opp_drive, /opp_drive2 ...    AckermannDriveStamped (in)
  /robot_description (the ego car's)         /ego_robot_description                  std_msgs/String (latched)

gym_bridge.py publishes scan and odometry with a plain depth (`create_publisher(LaserScan, ego_scan_topic, 10)`:
reliable, volatile, keep last 10), and so does the bridge under these names; gym_bridge_launch.py remaps the ego
car's robot_state_publisher's /robot_description to ego_robot_description (an opponent's keeps the sim's name).

Every other topic keeps its sim name. Frames: a car's frame `f` (`base_link`, or `car2/base_link` in a fleet)
becomes `<ns>/f` (`ego_racecar/base_link`, `opp_racecar/laser`), its wheel and hinge links under F1TENTH's URDF
names (`front_left_wheel`, `back_right_wheel`, `front_left_hinge`), and `map` stays `map`. The odometry's own frame
is folded into F1TENTH's tree, map -> <ns>/base_link: with `--odometry original` (map -> odom, the car's ground
truth pose) `odom` is `<ns>/base_link`, and the twist, which the original gives in the world frame, is turned into
the car's frame as f1tenth_gym_ros and nav_msgs give it; with `--odometry ros` (odom -> base_link) `odom` is `map`.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from racecar_sim.bridges.topic_map import rename_frames
from racecar_sim.core.names import NAVIGATION, ODOM, ROBOT_DESCRIPTION, WORLD_FRAME, CarNames
from racecar_sim.core.transforms import quat_to_matrix
from racecar_sim.msgs import Odometry, Twist, TwistWithCovariance, Vector3

EGO_NAMESPACE = "ego_racecar"  # sim.yaml: ego_namespace
OPP_NAMESPACE = "opp_racecar"  # sim.yaml: opp_namespace
SCAN, DRIVE = "scan", "drive"  # ego_scan_topic, ego_drive_topic
ODOM_TOPIC = "odom"  # ego_odom_topic and opp_odom_topic, under the car's namespace
OPP_SCAN, OPP_DRIVE = "opp_scan", "opp_drive"  # opp_scan_topic, opp_drive_topic (global, numbered)
ODOM_FRAME = "odom"  # the odometry node's frame (sensors/odometry.py)
EGO_DESCRIPTION = "ego_robot_description"  # gym_bridge_launch.py's remapping of the ego robot_state_publisher
QOS = "default"  # gym_bridge.py's publishers: a plain depth of 10 (bridges/ros2/qos.py's name)
LINK_NAMES = {  # the original racecar's links -> f1tenth_gym_ros's URDF (launch/ego_racecar.xacro)
    "left_rear_wheel": "back_left_wheel",
    "right_rear_wheel": "back_right_wheel",
    "left_front_wheel": "front_left_wheel",
    "right_front_wheel": "front_right_wheel",
    "left_steering_hinge": "front_left_hinge",
    "right_steering_hinge": "front_right_hinge",
}
_SIM_LINKS = {f1: ours for ours, f1 in LINK_NAMES.items()}
_SHARED_FRAMES = ("", WORLD_FRAME, "world")


def opp_suffix(number: int) -> str:
    """What f1tenth_gym_ros appends to the names of opponent `number` (1, 2, ...): '' for the first, then '2', '3'."""
    return "" if number == 1 else str(number)


@dataclass(frozen=True)
class F1tenthCar:
    """One car's names on both sides: the sim's (`names`, its lidar topic, odometry mode) and F1TENTH's."""

    names: CarNames
    scan_topic: str
    odometry: str  # "original" or "ros"
    index: int  # 0: the ego car, k: opponent k

    @property
    def namespace(self) -> str:
        """ego_racecar, opp_racecar, opp_racecar2, ..."""
        return EGO_NAMESPACE if self.index == 0 else OPP_NAMESPACE + opp_suffix(self.index)

    def topics(self) -> dict[str, str]:
        """The car's sim topics that F1TENTH names, and their names there."""
        if self.index == 0:
            scan, drive = f"/{SCAN}", f"/{DRIVE}"
        else:
            scan, drive = f"/{OPP_SCAN}{opp_suffix(self.index)}", f"/{OPP_DRIVE}{opp_suffix(self.index)}"
        topics = {
            self.scan_topic: scan,
            self.names.topic(ODOM): f"/{self.namespace}/{ODOM_TOPIC}",
            self.names.topic(NAVIGATION): drive,
        }
        if self.index == 0:
            topics[self.names.topic(ROBOT_DESCRIPTION)] = f"/{EGO_DESCRIPTION}"
        return topics

    def local(self, frame: str) -> str | None:
        """The car-relative name of a sim frame of this car (`car2/laser` -> `laser`), or None if not this car's."""
        if not self.names.namespace:
            return None if "/" in frame else frame
        prefix = self.names.namespace + "/"
        return frame[len(prefix) :] if frame.startswith(prefix) else None

    def f1tenth_frame(self, local: str) -> str:
        """F1TENTH's name of this car's frame `local`."""
        if local == ODOM_FRAME:
            return f"{self.namespace}/base_link" if self.odometry == "original" else WORLD_FRAME
        return f"{self.namespace}/{LINK_NAMES.get(local, local)}"


class F1tenthMap:
    """The topic map (bridges/topic_map.py's TopicMap) of f1tenth_gym_ros, for the cars given (the first is the ego
    car). Cars spawned later keep their sim names."""

    name = "f1tenth"

    def __init__(self, cars: Sequence[F1tenthCar]) -> None:
        self.cars = list(cars)
        self._to_ros: dict[str, str] = {}
        for car in self.cars:
            self._to_ros.update(car.topics())
        self._to_sim = {ros: sim for sim, ros in self._to_ros.items()}
        self._frames: dict[str, str] = {}  # sim frame -> F1TENTH frame, as met
        self._sim_frames: dict[str, str] = {}
        self._world_twist = {  # the child frames of odometry whose twist is in the world frame
            car.names.frame(ODOM_FRAME) for car in self.cars if car.odometry == "original"
        }
        by_namespace = {car.namespace: car for car in self.cars}
        self._by_namespace = by_namespace
        self._gym_published = {  # what gym_bridge.py publishes itself: scan and odometry
            ros
            for car in self.cars
            for sim, ros in car.topics().items()
            if sim in (car.scan_topic, car.names.topic(ODOM))
        }

    # --- topics ----------------------------------------------------------------------------------------------
    def ros_name(self, sim_topic: str) -> str | None:
        """F1TENTH's name for the topic (the sim's for a topic F1TENTH does not name)."""
        return self._to_ros.get(sim_topic, sim_topic)

    def sim_name(self, ros_topic: str) -> str | None:
        """The bus topic of a ROS topic; None for a sim name that goes out under an F1TENTH one (/vesc/odom)."""
        sim = self._to_sim.get(ros_topic)
        if sim is not None:
            return sim
        return None if ros_topic in self._to_ros else ros_topic

    def qos_name(self, ros_topic: str) -> str | None:
        """gym_bridge.py's QoS (a plain depth of 10) for the scan and odometry topics it publishes."""
        return QOS if ros_topic in self._gym_published else None

    # --- frames ----------------------------------------------------------------------------------------------
    def ros_frame(self, frame: str) -> str:
        """F1TENTH's name of a sim frame (a frame of no car of the map keeps its name)."""
        known = self._frames.get(frame)
        if known is None:
            known = frame
            if frame not in _SHARED_FRAMES:
                for car in self.cars:
                    local = car.local(frame)
                    if local is not None:
                        known = car.f1tenth_frame(local)
                        break
            self._frames[frame] = known
        return known

    def sim_frame(self, frame: str) -> str:
        """The sim's name of an F1TENTH frame (a frame under no car's namespace keeps its name)."""
        known = self._sim_frames.get(frame)
        if known is None:
            known = frame
            namespace, _, local = frame.partition("/")
            car = self._by_namespace.get(namespace)
            if car is not None and local:
                known = car.names.frame(_SIM_LINKS.get(local, local))
            self._sim_frames[frame] = known
        return known

    # --- messages --------------------------------------------------------------------------------------------
    def to_ros(self, sim_topic: str, msg: Any) -> Any:
        """The message with F1TENTH's frames (a copy; the bus's message is not changed); odometry in the world frame
        gets its twist in the car's frame."""
        if type(msg) is Odometry and msg.child_frame_id in self._world_twist:
            msg = _body_twist(msg)
        return rename_frames(msg, self.ros_frame)

    def from_ros(self, sim_topic: str, msg: Any) -> Any:
        """A message from ROS with the sim's frames."""
        return rename_frames(msg, self.sim_frame)


def _body_twist(msg: Odometry) -> Odometry:
    """A copy of `msg` with its twist turned from the world frame into the frame of its pose (the car's)."""
    o = msg.pose.pose.orientation
    back = quat_to_matrix(np.array([o.w, o.x, o.y, o.z])).T
    lin, ang = msg.twist.twist.linear, msg.twist.twist.angular
    vx, vy, vz = (float(v) for v in back @ np.array([lin.x, lin.y, lin.z]))
    wx, wy, wz = (float(v) for v in back @ np.array([ang.x, ang.y, ang.z]))
    twist = TwistWithCovariance(Twist(Vector3(vx, vy, vz), Vector3(wx, wy, wz)), msg.twist.covariance)
    return replace(msg, twist=twist)
