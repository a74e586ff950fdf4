"""What a run did, from its topics: the path, the speeds, the closest wall, the last scan and camera frame (RunLog),
and where each crash and each lap happened (RaceLog).

Its memory does not grow with the run: the figures (distance, mean speed, min clearance) are kept as running
totals, and the path for the plot is kept at most TRAJECTORY_ROWS rows long (a longer run keeps every other row).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from racecar_sim.bus import Bus, BusPort
from racecar_sim.drivers.odom import planar_position
from racecar_sim.msgs import Image, LaserScan, Odometry, String
from racecar_sim.runtime.collisions import COLLISIONS, MAX_KEPT
from racecar_sim.runtime.laps import LAP

if TYPE_CHECKING:
    from racecar_sim.runtime.simulator import Simulator
    from racecar_sim.sensors.camera import CameraPublisher

TRAJECTORY_ROWS = 1 << 14  # the most path rows kept per car (819 s at 20 Hz, 384 KB); then every other one is dropped
_MINIMUM = np.minimum.reduce  # what ndarray.min() calls (NaN propagates the same)
ODOMETRY_RATE = 20.0  # Hz, the rows of `trajectory` until it is thinned out


class RunLog:
    """Subscribes to /vesc/odom, /scan and the camera image of one car; summarises the run for people.

    A fleet's car has its own topics: `RunLog(bus, car.topic("/scan"), None, odom_topic=car.topic("/vesc/odom"))`.

    `trajectory` rows are x, y (m) and ground speed (m/s) at the odometry rate (20 Hz), `trajectory_rate` rows per
    sim second: past TRAJECTORY_ROWS rows every other one is dropped and the rate halves (memory stays flat in a long
    run); the last row is always the last odometry. `distance` (m) and `mean_speed` (m/s) are summed over every
    odometry message. `min_clearance` is the shortest lidar range seen (m): how close the car came to a wall.
    """

    def __init__(
        self,
        bus: BusPort,
        scan_topic: str | None = "/scan",
        image_topic: str | None = "/camera/zed/rgb/image_rect_color",
        odom_topic: str = "/vesc/odom",
    ) -> None:
        self._path = np.empty((TRAJECTORY_ROWS, 3))  # rows taken every `_stride`-th odometry message
        self._kept = 0  # rows of _path in use
        self._stride = 1
        self._count = 0  # odometry messages seen
        self._last_row: tuple[float, float, float] | None = None
        self._first_ns = self._last_ns = 0
        self.distance = 0.0
        self.min_clearance = math.inf
        self.last_scan: LaserScan | None = None
        self.last_pose: tuple[float, float, float] | None = None  # x, y, yaw
        self.last_image: Image | None = None
        self.images = 0
        bus.subscribe(odom_topic, self._on_odom)
        if scan_topic:
            bus.subscribe(scan_topic, self._on_scan)
        if image_topic:  # overheard: the camera draws for the summary's last frame alone only at the end (take_frame)
            if isinstance(bus, Bus):
                bus.overhear(image_topic, self._on_image)
            else:
                bus.subscribe(image_topic, self._on_image)

    def _on_odom(self, msg: Odometry) -> None:
        x, y, yaw = planar_position(msg)
        v = msg.twist.twist.linear
        stamp = msg.header.stamp.to_ns()
        last = self._last_row
        if last is not None:
            self.distance += math.hypot(x - last[0], y - last[1])
        else:
            self._first_ns = stamp
        row = (x, y, math.hypot(v.x, v.y))
        if self._count % self._stride == 0:
            if self._kept == TRAJECTORY_ROWS:  # full: keep every other row, and every other one from now on
                half = self._path[::2].copy()
                self._path[: len(half)] = half
                self._kept, self._stride = len(half), self._stride * 2
            if self._count % self._stride == 0:
                self._path[self._kept] = row
                self._kept += 1
        self._count += 1
        self._last_row = row
        self._last_ns = stamp
        self.last_pose = (x, y, yaw)

    def _on_scan(self, msg: LaserScan) -> None:
        ranges = np.asarray(msg.ranges)
        # the shortest finite range: the plain minimum (inf, no echo, is above every range), unless a NaN or -inf is
        # in the scan; a third of the time of picking the finite ones out first (every scan of every car). The
        # minimum is read at argmin, a third of the time of min()'s reduction: the first NaN where there is one, as
        # min() gives NaN; at a zero min() is asked, as a tie of 0.0 and -0.0 may keep either sign
        lowest = float(ranges[ranges.argmin()]) if len(ranges) else math.inf
        if lowest == 0.0:
            lowest = float(_MINIMUM(ranges))
        if math.isnan(lowest) or lowest == -math.inf:
            finite = ranges[np.isfinite(ranges)]
            lowest = float(finite.min()) if len(finite) else math.inf
        if lowest < self.min_clearance:
            self.min_clearance = lowest
        self.last_scan = msg

    def _on_image(self, msg: Image) -> None:
        self.last_image = msg
        self.images += 1

    def take_frame(self, camera: CameraPublisher, stamp_ns: int) -> None:
        """Where no camera frame was published (nobody but this log wanted one), `camera`'s frame of now, stamped
        `stamp_ns`, as the last image: the one frame the summary shows, drawn once instead of every frame of the run.
        At the end of a run whose length is a whole number of camera periods it is the frame the camera's last tick
        would have published."""
        if self.last_image is None:
            self.last_image = camera.frame(stamp_ns)

    @property
    def trajectory(self) -> np.ndarray:
        """(N, 3): x, y, ground speed; row i at i / trajectory_rate s, and the last odometry as the last row."""
        path = self._path[: self._kept]
        if self._last_row is not None and (self._count - 1) % self._stride:  # the last message was not kept
            return np.vstack([path, self._last_row])
        trajectory: np.ndarray = path.copy()
        return trajectory

    @property
    def trajectory_rate(self) -> float:
        """Rows of `trajectory` per sim second (ODOMETRY_RATE until the path is thinned out)."""
        return ODOMETRY_RATE / self._stride

    @property
    def mean_speed(self) -> float:
        """Distance over the time the odometry covered (m/s)."""
        span = (self._last_ns - self._first_ns) / 1e9
        return self.distance / span if span > 0 else 0.0

    def last_frame(self) -> np.ndarray | None:
        """The last camera image as an H x W x 3 BGR array."""
        return image_array(self.last_image) if self.last_image is not None else None


def image_array(msg: Image) -> np.ndarray:
    """A bgr8 / rgb8 Image's pixels as an H x W x 3 uint8 array (BGR order)."""
    return msg.bgr_pixels()


@dataclass(frozen=True)
class RaceMark:
    """Where a car was when one of its crashes started or one of its laps ended: sim time (s), x, y (m), and what:
    the thing or car it hit, or the lap's number and time ("2: 64.10 s")."""

    time: float
    x: float
    y: float
    what: str


class RaceLog:
    """The places of the run's crashes (/racecar_sim/collisions) and lap ends (/racecar_sim/lap), per car (model
    name), for the summary's plot: each car's position at the moment the crash was announced or the lap counted.

    The figures themselves (times, counts, what was hit) are `sim.collisions` and `sim.laps`'; this adds the places.
    At most MAX_KEPT marks of each kind are kept per car.
    """

    def __init__(self, sim: Simulator) -> None:
        self.sim = sim
        self.crashes: dict[str, list[RaceMark]] = {}
        self.laps: dict[str, list[RaceMark]] = {}
        sim.subscribe(COLLISIONS, self._on_crash)
        sim.subscribe(LAP, self._on_lap)

    def _mark(self, marks: dict[str, list[RaceMark]], car: str, what: str) -> None:
        kept = marks.setdefault(car, [])
        if len(kept) >= MAX_KEPT:
            return
        try:
            position, _ = self.sim.car_named(car).state.base_pose()
        except Exception:  # a car deleted since (a Gazebo delete_model): no place to mark
            return
        kept.append(RaceMark(self.sim.time, float(position[0]), float(position[1]), what))

    def _on_crash(self, msg: String) -> None:
        car, _, what = msg.data.partition(" ")
        self._mark(self.crashes, car, what)
        if what in {c.model_name for c in self.sim.cars}:  # two cars: a mark on each one's path
            self._mark(self.crashes, what, car)

    def _on_lap(self, msg: String) -> None:
        car, count, last, *_ = msg.data.split(" ")
        self._mark(self.laps, car, f"{count}: {float(last):.2f} s")


def race_results(sim: Simulator, car: str) -> dict[str, Any]:
    """One car's race figures: laps (None where the world has no start line), each lap's time, the best lap (s), and
    its crashes (sim time, what it hit: a wall's model::link or the other car, kind "wall" or "car")."""
    record = sim.laps.records.get(car) if sim.laps is not None else None
    crashes = []
    for crash in sim.collisions.crashes_of(car):
        other = crash.what if crash.car == car else crash.car
        crashes.append({"time": crash.time_ns / 1e9, "what": other, "kind": crash.kind})
    return {
        "laps": None if sim.laps is None else (record.count if record is not None else 0),
        "lap_times": [] if record is None else record.times,
        "best_lap": None if record is None else record.best,
        "crash_count": len(crashes),
        "crashes": crashes,
    }
