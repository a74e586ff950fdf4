"""Drivers: nodes that publish AckermannDriveStamped commands on a mux input.

wall-follow and pure-pursuit read only /scan and /vesc/odom, as a driver on the real car would.
"""

from racecar_sim.drivers.config import PurePursuitConfig, WallFollowConfig, pure_pursuit_config, wall_follow_config
from racecar_sim.drivers.constant import NAVIGATION, ConstantCommand
from racecar_sim.drivers.odom import PlanarPose, planar_pose
from racecar_sim.drivers.pure_pursuit import PurePursuit
from racecar_sim.drivers.wall_follow import WallFollower
from racecar_sim.drivers.waypoints import Waypoints, load_waypoints

__all__ = [
    "NAVIGATION",
    "ConstantCommand",
    "PlanarPose",
    "PurePursuit",
    "PurePursuitConfig",
    "WallFollowConfig",
    "WallFollower",
    "Waypoints",
    "load_waypoints",
    "planar_pose",
    "pure_pursuit_config",
    "wall_follow_config",
]
