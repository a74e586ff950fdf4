"""pure-pursuit: follow a centerline or waypoint path, steering onto the point one look-ahead away."""

from __future__ import annotations

import math

import numpy as np

from racecar_sim.bus import BusPort
from racecar_sim.drivers.config import PurePursuitConfig, pure_pursuit_config
from racecar_sim.drivers.constant import NAVIGATION
from racecar_sim.drivers.odom import planar_pose
from racecar_sim.drivers.waypoints import Waypoints
from racecar_sim.msgs import AckermannDrive, AckermannDriveStamped, Header, Odometry
from racecar_sim.nodes import NodeBase

SEARCH_AHEAD = 4.0  # m of path searched past the last nearest point (keeps loops that pass close from jumping)


class PurePursuit(NodeBase):
    """A navigation node: from /vesc/odom only, it drives base_link (the rear axle) along `path`.

    The goal is the path point `lookahead` ahead of the nearest point (further at speed); the arc
    through it has curvature κ = 2·y/L² in the car's frame, steered as δ = atan(wheelbase·κ). The speed
    is the path's own (a third CSV column) or `speed`, capped so the lateral acceleration stays within
    `max_lateral_accel`. On an open path it stops at the end.
    """

    def __init__(
        self,
        bus: BusPort,
        path: Waypoints,
        config: PurePursuitConfig | None = None,
        topic: str = NAVIGATION,
        odom_topic: str = "/vesc/odom",
    ) -> None:
        self.config = config or pure_pursuit_config()
        self.bus, self.topic, self.path = bus, topic, path
        points = path.points
        self._segments = (np.roll(points, -1, axis=0) if path.closed else points[1:]) - (
            points if path.closed else points[:-1]
        )
        self._lengths = np.hypot(*self._segments.T)
        self._station = np.concatenate([[0.0], np.cumsum(self._lengths)])  # arc length at each point
        self.length = float(self._station[-1])
        self.progress = 0.0  # arc length of the car's nearest point, unwrapped over laps
        self._nearest: float | None = None
        bus.subscribe(odom_topic, self._on_odom)

    @property
    def laps(self) -> float:
        """How many times round the loop the car has gone (progress / loop length)."""
        return self.progress / self.length

    def _project(self, xy: np.ndarray, lo: float, hi: float) -> float:
        """Arc length of the path point nearest to `xy` among stations in [lo, hi] (mod length if closed)."""
        rel = xy - self.path.points[: len(self._segments)]
        t = np.clip(np.einsum("ij,ij->i", rel, self._segments) / self._lengths**2, 0.0, 1.0)
        foot = self.path.points[: len(self._segments)] + t[:, None] * self._segments
        station = self._station[:-1] + t * self._lengths
        if self.path.closed:
            ahead = (station - lo) % self.length
            window = ahead <= hi - lo
        else:
            window = (station >= lo) & (station <= hi)
        d2 = np.where(window, np.einsum("ij,ij->i", xy - foot, xy - foot), np.inf)
        return float(station[int(np.argmin(d2))])

    def _point_at(self, s: float) -> np.ndarray:
        s = s % self.length if self.path.closed else min(max(s, 0.0), self.length)
        i = min(int(np.searchsorted(self._station, s, side="right")) - 1, len(self._segments) - 1)
        return self.path.points[i] + self._segments[i] * ((s - self._station[i]) / self._lengths[i])

    def _speed_at(self, s: float) -> float:
        if self.path.speeds is None:
            return self.config.speed
        s = s % self.length if self.path.closed else min(s, self.length)
        i = min(int(np.searchsorted(self._station, s, side="right")) - 1, len(self.path.speeds) - 1)
        return float(self.path.speeds[i])

    def _on_odom(self, msg: Odometry) -> None:
        cfg = self.config
        pose = planar_pose(msg)
        xy = np.array([pose.x, pose.y])
        if self._nearest is None:
            nearest = self._project(xy, 0.0, self.length)
        else:
            nearest = self._project(xy, self._nearest - 0.5, self._nearest + SEARCH_AHEAD)
            step = (nearest - self._nearest) % self.length if self.path.closed else nearest - self._nearest
            self.progress += step if step < self.length / 2 else step - self.length
        self._nearest = nearest
        lookahead = float(
            np.clip(cfg.lookahead + cfg.lookahead_time * max(pose.speed, 0.0), cfg.min_lookahead, cfg.max_lookahead)
        )
        goal = self._point_at(nearest + lookahead)
        dx, dy = goal - xy
        y_car = -math.sin(pose.yaw) * dx + math.cos(pose.yaw) * dy
        distance2 = max(dx * dx + dy * dy, 1e-6)
        curvature = 2.0 * y_car / distance2
        steering = float(np.clip(math.atan(cfg.wheelbase * curvature), -cfg.max_steering, cfg.max_steering))
        speed = min(self._speed_at(nearest), math.sqrt(cfg.max_lateral_accel / max(abs(curvature), 1e-6)))
        speed = max(speed, cfg.min_speed)
        if not self.path.closed and self.length - nearest < 0.05:
            speed, steering = 0.0, 0.0
        stamp = msg.header.stamp.to_ns()
        self.bus.publish(
            self.topic,
            AckermannDriveStamped(Header.at(stamp, "base_link"), AckermannDrive(steering_angle=steering, speed=speed)),
        )
