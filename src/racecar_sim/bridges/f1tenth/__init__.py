"""The F1TENTH interface (`--topic-map f1tenth`): f1tenth_gym_ros's topics, frames, /map and /initialpose, so that a
ROS stack written for it (pure pursuit, follow-the-gap, a particle filter) runs unchanged against the sim.

`F1tenthInterface(sim)` is the topic map a bridge applies at its edge (topics.py: names and frames on ROS; the bus
and the recording keep the sim's) and starts the world nodes F1TENTH's stack expects on the bus (nodes.py: /map
from the world's geometry, /initialpose and /goal_pose moving the cars).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from racecar_sim.bridges.f1tenth.grid import RESOLUTION, Grid, occupancy_grid, slice_world
from racecar_sim.bridges.f1tenth.nodes import GOAL_POSE, INITIAL_POSE, MAP, InitialPose, MapServer, scan_height
from racecar_sim.bridges.f1tenth.topics import EGO_NAMESPACE, OPP_NAMESPACE, F1tenthCar, F1tenthMap, opp_suffix
from racecar_sim.sensors.lidar import ORIGINAL_TOPIC

if TYPE_CHECKING:
    from racecar_sim.runtime import Simulator

__all__ = [
    "EGO_NAMESPACE",
    "GOAL_POSE",
    "INITIAL_POSE",
    "MAP",
    "OPP_NAMESPACE",
    "RESOLUTION",
    "F1tenthCar",
    "F1tenthInterface",
    "F1tenthMap",
    "Grid",
    "InitialPose",
    "MapServer",
    "occupancy_grid",
    "opp_suffix",
    "scan_height",
    "slice_world",
]


class F1tenthInterface(F1tenthMap):
    """F1TENTH's names for the sim's cars (the first is the ego car, the others opponents 1, 2, ...), and the world
    nodes /map and /initialpose on the sim's bus (held with the sim's world nodes: they live as long as it does).

    `resolution` (m per cell) and `height` (m; default the ego lidar's) choose the map's slice of the world.
    """

    def __init__(self, sim: Simulator, resolution: float = RESOLUTION, height: float | None = None) -> None:
        super().__init__(
            [
                F1tenthCar(
                    car.names, car.lidar.topic if car.lidar else car.topic(ORIGINAL_TOPIC), car.odometry_mode, index
                )
                for index, car in enumerate(sim.cars)
            ]
        )
        self.map_server = MapServer(sim, resolution, height)
        self.initial_pose = InitialPose(sim, list(sim.cars), opp_suffix)
        sim.world_nodes.extend([self.map_server, self.initial_pose])
