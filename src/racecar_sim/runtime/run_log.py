"""What a run did, from its topics: the path, the speeds, the closest wall, the last scan and camera frame."""

from __future__ import annotations

import math

import numpy as np

from racecar_sim.bus import Bus
from racecar_sim.drivers.odom import planar_pose
from racecar_sim.msgs import Image, LaserScan, Odometry


class RunLog:
    """Subscribes to /vesc/odom, /scan and the camera image of one car; summarises the run for people.

    A fleet's car has its own topics: `RunLog(bus, car.topic("/scan"), None, odom_topic=car.topic("/vesc/odom"))`.

    `trajectory` rows are x, y (m) and ground speed (m/s) at the odometry rate (20 Hz).
    `min_clearance` is the shortest lidar range seen (m): how close the car came to a wall, from the laser.
    """

    def __init__(self, bus: Bus, scan_topic: str | None = "/scan",
                 image_topic: str | None = "/camera/zed/rgb/image_rect_color", odom_topic: str = "/vesc/odom") -> None:
        self._rows: list[tuple[float, float, float]] = []
        self._times: list[int] = []
        self.distance = 0.0
        self.min_clearance = math.inf
        self.last_scan: LaserScan | None = None
        self.last_pose: tuple[float, float, float] | None = None  # x, y, yaw
        self.last_image: Image | None = None
        self.images = 0
        bus.subscribe(odom_topic, self._on_odom)
        if scan_topic:
            bus.subscribe(scan_topic, self._on_scan)
        if image_topic:
            bus.subscribe(image_topic, self._on_image)

    def _on_odom(self, msg: Odometry) -> None:
        pose = planar_pose(msg)
        v = msg.twist.twist.linear
        if self._rows:
            x, y, _ = self._rows[-1]
            self.distance += math.hypot(pose.x - x, pose.y - y)
        self._rows.append((pose.x, pose.y, math.hypot(v.x, v.y)))
        self._times.append(msg.header.stamp.to_ns())
        self.last_pose = (pose.x, pose.y, pose.yaw)

    def _on_scan(self, msg: LaserScan) -> None:
        ranges = np.asarray(msg.ranges)
        finite = ranges[np.isfinite(ranges)]
        if len(finite):
            self.min_clearance = min(self.min_clearance, float(finite.min()))
        self.last_scan = msg

    def _on_image(self, msg: Image) -> None:
        self.last_image = msg
        self.images += 1

    @property
    def trajectory(self) -> np.ndarray:
        """(N, 3): x, y, ground speed."""
        return np.array(self._rows, dtype=np.float64).reshape(-1, 3)

    @property
    def mean_speed(self) -> float:
        """Distance over the time the odometry covered (m/s)."""
        span = (self._times[-1] - self._times[0]) / 1e9 if self._times else 0.0
        return self.distance / span if span > 0 else 0.0

    def last_frame(self) -> np.ndarray | None:
        """The last camera image as an H x W x 3 BGR array."""
        return image_array(self.last_image) if self.last_image is not None else None


def image_array(msg: Image) -> np.ndarray:
    """A bgr8 / rgb8 Image's pixels as an H x W x 3 uint8 array (BGR order)."""
    return msg.bgr_pixels()
