"""The world nodes F1TENTH's stack expects beside the cars: map_server's /map, and /initialpose (and /goal_pose for the
opponents) putting a car where RViz's pose tools say.

/map: nav_msgs/OccupancyGrid in frame `map`, latched (transient-local on ROS 2, as map_server publishes it), made
once from the world sliced at the ego car's lidar height (grid.py).

/initialpose (geometry_msgs/PoseWithCovarianceStamped, RViz's "2D Pose Estimate"): the ego car is teleported there,
as f1tenth_gym_ros resets its ego agent, through the Gazebo API's set_model_state: sim time goes on (a reset to t = 0
would send every sim-time node's clock backwards) and the other cars stay where they are, driving. The car keeps its
height above the ground (its spawn height), takes the pose's heading (yaw), and stops (zero twist). /goal_pose
(geometry_msgs/PoseStamped, RViz's "2D Goal Pose"), /goal_pose2, ... do the same for opponent 1, 2, ...
A pose that is not finite, in a frame other than `map`, or where the car would be inside a wall or over nothing is
dropped with one warning naming it (repeated at most every 5 s), and the car stays where it was.
"""

from __future__ import annotations

import logging
import math
import warnings
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import mujoco

from racecar_sim.bridges.f1tenth.grid import RESOLUTION, occupancy_grid, slice_world
from racecar_sim.bus import type_name
from racecar_sim.core.errors import RacecarSimError
from racecar_sim.core.names import WORLD_FRAME
from racecar_sim.core.throttle import ThrottledWarning
from racecar_sim.core.time import NS_PER_S
from racecar_sim.core.transforms import yaw_of
from racecar_sim.msgs import (
    Header,
    MapMetaData,
    ModelState,
    OccupancyGrid,
    Point,
    Pose,
    PoseStamped,
    PoseWithCovarianceStamped,
    Quaternion,
    Time,
    Twist,
)
from racecar_sim.msgs.gazebo_msgs import SetModelStateRequest
from racecar_sim.nodes import NodeBase
from racecar_sim.physics import check_spawn
from racecar_sim.worlds import Spawn

if TYPE_CHECKING:
    from racecar_sim.runtime import Car, Simulator

log = logging.getLogger("racecar_sim")

MAP = "/map"
INITIAL_POSE = "/initialpose"
GOAL_POSE = "/goal_pose"
SET_MODEL_STATE = "/gazebo/set_model_state"
DEFAULT_SCAN_HEIGHT = 0.1  # m: the map's slice when the ego car has no lidar


class MapServer(NodeBase):
    """map_server: the world's OccupancyGrid on /map, latched, published once."""

    def __init__(self, sim: Simulator, resolution: float = RESOLUTION, height: float | None = None) -> None:
        self.height = scan_height(sim.car) if height is None else height
        around = [(spawn.x, spawn.y) for spawn in sim.spawns]
        self.grid = occupancy_grid(slice_world(sim.model, self.height), around, resolution, sim.world.label)
        rows, columns = self.grid.cells.shape
        stamp = Time(sim.time_ns // NS_PER_S, sim.time_ns % NS_PER_S)
        origin = Pose(Point(self.grid.origin[0], self.grid.origin[1], 0.0), Quaternion())
        self.msg = OccupancyGrid(
            Header(stamp, WORLD_FRAME),
            MapMetaData(stamp, self.grid.resolution, columns, rows, origin),
            self.grid.cells.reshape(-1),
        )
        sim.bus.latch(MAP)
        sim.bus.publish(MAP, self.msg)


def scan_height(car: Car) -> float:
    """The height of the car's lidar beams above the world's z = 0 now (DEFAULT_SCAN_HEIGHT without a lidar)."""
    lidar = car.lidar
    if lidar is None:
        return DEFAULT_SCAN_HEIGHT
    origin, _ = lidar.ray_origin()
    return float(origin[2])


class InitialPose(NodeBase):
    """/initialpose for the ego car (`cars[0]`), /goal_pose, /goal_pose2, ... for the opponents."""

    def __init__(self, sim: Simulator, cars: list[Car], goal_suffix: Callable[[int], str]) -> None:
        self.sim = sim
        self._warn = ThrottledWarning(log, lambda: sim.time_ns)
        self.topics: dict[str, Car] = {}
        for index, car in enumerate(cars):
            if index == 0:
                self._listen(INITIAL_POSE, PoseWithCovarianceStamped, car)
            else:
                self._listen(GOAL_POSE + goal_suffix(index), PoseStamped, car)
        self.heights = {car.model_name: spawn.z for car, spawn in zip(sim.cars, sim.spawns)}
        self.moved = 0  # poses taken

    def _listen(self, topic: str, cls: type, car: Car) -> None:
        self.topics[topic] = car

        def on_pose(msg: Any) -> None:
            self._on_pose(topic, cls, msg)

        self.sim.bus.subscribe(topic, on_pose, cls)

    def _on_pose(self, topic: str, cls: type, msg: Any) -> None:
        if not _of_class(msg, cls):
            self._warn(topic, "%s: ignored a %s message (the topic takes %s)", topic, type_name(msg), type_name(cls))
            return
        header: Header = msg.header
        pose: Pose = msg.pose.pose if isinstance(msg, PoseWithCovarianceStamped) else msg.pose
        if header.frame_id not in ("", WORLD_FRAME):
            self._warn(topic, "%s: ignored a pose in frame %r (it takes poses in map)", topic, header.frame_id)
            return
        p, o = pose.position, pose.orientation
        values = (p.x, p.y, o.w, o.x, o.y, o.z)
        if not all(math.isfinite(v) for v in values) or not any((o.w, o.x, o.y, o.z)):
            self._warn(topic, "%s: ignored a pose that is not finite numbers (or a zero quaternion)", topic)
            return
        car = self.topics[topic]
        if car not in self.sim.cars:  # deleted since
            return
        error = self.teleport(car, p.x, p.y, yaw_of((o.w, o.x, o.y, o.z)))
        if error:
            self._warn(topic, "%s: ignored: %s", topic, error)

    def teleport(self, car: Car, x: float, y: float, yaw: float) -> str | None:
        """Put `car` at (x, y, yaw) at its spawn height, stopped; the reason (and the car left as it was) if the pose
        is refused."""
        sim = self.sim
        model, data = sim.model, sim.data
        saved = data.qpos.copy(), data.qvel.copy(), data.act.copy()
        z = self.heights.get(car.model_name, Spawn().z)
        half = 0.5 * yaw
        pose = Pose(Point(x, y, z), Quaternion(0.0, 0.0, math.sin(half), math.cos(half)))
        state = ModelState(car.model_name, pose, Twist(), WORLD_FRAME)
        response = sim.bus.call(SET_MODEL_STATE, SetModelStateRequest(state))
        if not response.success:
            return str(response.status_message)
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")  # a drop onto the ground below is no reason to refuse
                check_spawn(model, data, sim.world, car.robot, car.names, Spawn(x, y, z, yaw), car.model_name)
        except RacecarSimError as exc:
            data.qpos[:], data.qvel[:], data.act[:] = saved
            mujoco.mj_forward(model, data)
            sim.poses_changed()
            return str(exc)
        self.moved += 1
        return None


def _of_class(msg: object, cls: type) -> bool:
    """Whether `msg` is of exactly the class `cls` (as the bus's typed topics take it)."""
    return type(msg) is cls
