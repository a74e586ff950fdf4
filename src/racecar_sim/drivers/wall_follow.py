"""wall-follow: hold a distance to the right or left wall with a PID on the lidar, as in the F1TENTH lab."""

from __future__ import annotations

import math
import sys
from collections.abc import Callable

import numpy as np

from racecar_sim.bus import BusPort
from racecar_sim.core.time import NS_PER_S
from racecar_sim.drivers.config import WallFollowConfig, wall_follow_config
from racecar_sim.drivers.constant import NAVIGATION
from racecar_sim.drivers.odom import planar_pose
from racecar_sim.msgs import AckermannDrive, AckermannDriveStamped, Header, LaserScan, Odometry
from racecar_sim.nodes import NodeBase

_READ_SCAN: Callable[..., tuple[bool, float, float, float]] | None = None  # wall_fit.read_scan, once imported (numba)


def _read_scan() -> Callable[..., tuple[bool, float, float, float]]:
    """wall_fit.read_scan, imported at the first call and kept: an import statement costs a look-up per scan."""
    global _READ_SCAN
    from racecar_sim.drivers.wall_fit import read_scan

    _READ_SCAN = read_scan
    return read_scan


# the side sector (beam indices, and their unit vectors: rows cos, sin) and the front cone (beam indices)
Layout = tuple[slice | np.ndarray, np.ndarray, slice | np.ndarray]


def _clip(value: float, low: float, high: float) -> float:
    """np.clip of one float, without numpy's per-call cost."""
    return float(min(max(value, low), high))


def _span(indices: np.ndarray) -> slice | np.ndarray:
    """Increasing beam indices as a slice when they are consecutive (they are: angles grow along a scan)."""
    if len(indices) == 0:
        return slice(0, 0)
    if indices[-1] - indices[0] + 1 == len(indices):
        return slice(int(indices[0]), int(indices[-1]) + 1)
    return indices


class WallFollower(NodeBase):
    """A navigation node: from /scan and /vesc/odom only, it steers to keep `distance` to one wall.

    A line fitted to the nearest beam ends on the wall's side gives the car's approach angle β to the
    wall and its distance D; projected `lookahead` ahead, D − L·sin β is the
    distance the PID holds. It is a cascade: the distance error asks for an approach angle (P + I,
    clipped to `max_approach`, so a far wall is approached gently rather than in circles), and the
    steering turns the car to that angle (the D term: β is the distance's rate over the speed, read
    from the wall's geometry instead of differencing noisy scans). A wall straight ahead closer than
    `front_turn` adds a turn away from the followed wall (that is how it rounds a dead end); the speed
    falls with the steering and the free distance ahead. Boxed in closer than `stuck`, it backs out.
    """

    def __init__(
        self,
        bus: BusPort,
        config: WallFollowConfig | None = None,
        topic: str = NAVIGATION,
        scan_topic: str = "/scan",
        odom_topic: str = "/vesc/odom",
    ) -> None:
        self.config = config or wall_follow_config()
        self.bus, self.topic = bus, topic
        self.side = -1.0 if self.config.side == "right" else 1.0  # the wall's side as a sign of the beam angle
        self.speed = 0.0
        self.error = 0.0
        self._integral = 0.0
        self._last_ns: int | None = None
        self._range_max = 10.0
        self._reverse_until = -1
        self._scan_layout: tuple[tuple[float, float, int], np.ndarray] | None = None  # (angle_min, increment, count)
        self._angles = np.empty(0)  # the beam angles _layout is for
        self._layout: Layout = (slice(0, 0), np.empty((2, 0)), slice(0, 0))
        bus.subscribe(odom_topic, self._on_odom)
        bus.subscribe(scan_topic, self._on_scan)
        if "numba" in sys.modules:  # loaded for the world's walls (runtime/compiled.py): the fit's kernels now, at the
            from racecar_sim.drivers.wall_fit import fit_wall, read_scan  # start, not at the first scans

            fit_wall(np.ones(2, np.float32), np.ones(2), np.zeros(2), 10.0, self.config.patch, self.side)
            read_scan(
                np.ones(2, np.float32), 0, 2, np.ones(2), np.zeros(2), 0, 2, 10.0, float(self.config.patch), self.side
            )

    def _on_odom(self, msg: Odometry) -> None:
        self.speed = planar_pose(msg).speed

    def _read(self, ranges: np.ndarray, angles: np.ndarray) -> tuple[float, float, float] | None:
        """_readings of a float32 scan without NaN or -inf (a lidar's), in one compiled call (wall_fit.read_scan), where
        numba is loaded already (a world with walls) and the sector and cone are runs of beams; None otherwise."""
        if "numba" not in sys.modules or ranges.dtype != np.float32 or ranges.ndim != 1:
            return None
        if not ranges.flags.c_contiguous:
            return None
        sector, beams, front = self._beams(angles)
        if type(sector) is not slice or type(front) is not slice:
            return None
        read_scan = _READ_SCAN or _read_scan()
        clean, approach, wall, ahead = read_scan(
            ranges,
            sector.start,
            sector.stop,
            beams[0],
            beams[1],
            front.start,
            front.stop,
            float(self._range_max),
            float(self.config.patch),
            float(self.side),
        )
        return (approach, wall, ahead) if clean else None

    def _readings(self, ranges: np.ndarray, angles: np.ndarray) -> tuple[float, float, float]:
        """The wall's approach angle and distance (_wall) and the free distance ahead (the front cone's shortest
        range, range_max where it is empty or farther) of a scan's ranges; NaN reads as 0 m, -inf as range_max."""
        lowest = float(ranges.min()) if len(ranges) else 0.0
        if math.isnan(lowest) or lowest == -math.inf:  # as nan_to_num reads them: 0 and range_max
            ranges = np.nan_to_num(np.asarray(ranges, np.float64), posinf=self._range_max, neginf=self._range_max)
        approach, wall = self._wall(ranges, angles)
        front_ranges = ranges[self._layout[2]]  # +inf (no echo) reads as range_max
        front = min(float(front_ranges.min()), self._range_max) if len(front_ranges) else self._range_max
        return approach, wall, front

    def _wall(self, ranges: np.ndarray, angles: np.ndarray) -> tuple[float, float]:
        """The approach angle (rad, > 0 heading into it) and distance (m) of the wall on the followed side.

        The wall is a line fitted to the beam ends within `patch` of the nearest one in the side sector:
        along a straight wall that is the wall; at a wall's end it is the corner, which the car then rounds
        at `distance`, because the fitted line turns with the bearing of the nearest point.
        `ranges` has no NaN or -inf (nan_to_num has read them).
        """
        sector, beams, _ = self._beams(angles)
        return self._fit(ranges[sector], beams)

    def _fit(self, ranges: np.ndarray, beams: np.ndarray) -> tuple[float, float]:
        """`_wall` on the side sector's ranges (none NaN or -inf) and their beams' unit vectors (2, n: cos, sin).

        The line is the patch's total-least-squares fit: through its centroid c, along the principal axis of its
        scatter matrix, at half the argument of sum((p - c)^2) (the closed form of that 2x2 eigenvector; an SVD of
        the patch gives the same axis at ten times the cost). The patch: the beam ends within `patch` (by hypot) of
        the nearest one (the shortest range, or by x^2 + y^2 where another is within rounding of it). Compiled
        (wall_fit.py) once two beams echo: a scan with less is decided here, without loading numba.
        """
        if np.count_nonzero(ranges < self._range_max) < 2:
            return 0.0, self._range_max
        from racecar_sim.drivers.wall_fit import fit_wall

        return fit_wall(ranges, beams[0], beams[1], self._range_max, self.config.patch, self.side)

    def _beams(self, angles: np.ndarray) -> Layout:
        """The side sector (its beams, and their unit vectors: rows cos, sin) and the front cone (its beams) of
        scans with these beam angles; worked out once per scan layout."""
        if angles is not self._angles and not np.array_equal(angles, self._angles):
            cfg = self.config
            bearing = self.side * angles
            sector = np.flatnonzero((bearing >= math.radians(cfg.sector[0])) & (bearing <= math.radians(cfg.sector[1])))
            front = np.flatnonzero(np.abs(angles) <= math.radians(cfg.front_cone))
            self._angles = angles
            beams = np.array([np.cos(angles[sector]), np.sin(angles[sector])])
            self._layout = (_span(sector), beams, _span(front))
        return self._layout

    def _scan_angles(self, scan: LaserScan, count: int) -> np.ndarray:
        """The beam angles of a scan: the same array object for every scan of the same layout."""
        key = (scan.angle_min, scan.angle_increment, count)
        if self._scan_layout is None or self._scan_layout[0] != key:
            self._scan_layout = key, scan.angle_min + scan.angle_increment * np.arange(count)
        return self._scan_layout[1]

    def _on_scan(self, scan: LaserScan) -> None:
        cfg = self.config
        self._range_max = scan.range_max
        ranges = np.asarray(scan.ranges)
        angles = self._scan_angles(scan, len(ranges))
        read = self._read(ranges, angles)
        if read is not None:  # a lidar's scan: its readings in one compiled call
            approach, wall, front = read
        else:
            approach, wall, front = self._readings(ranges, angles)
        ahead = cfg.lookahead + cfg.lookahead_time * max(self.speed, 0.0)
        distance = wall - ahead * math.sin(approach)
        error = distance - cfg.distance  # > 0: too far from the wall

        now = scan.header.stamp.to_ns()
        dt = 0.0 if self._last_ns is None else (now - self._last_ns) / NS_PER_S
        self._last_ns, self.error = now, error
        if cfg.ki:
            limit = cfg.max_approach / cfg.ki
            self._integral = _clip(self._integral + error * dt, -limit, limit)
        wanted = _clip(cfg.kp * error + cfg.ki * self._integral, -cfg.max_approach, cfg.max_approach)
        steer_away = cfg.kd * (approach - wanted)

        if front < cfg.stuck or now < self._reverse_until:
            # boxed in (an acute pocket, a dead end too tight to turn in): back out, swinging the nose away
            if now >= self._reverse_until:
                self._reverse_until = now + int(cfg.reverse_time * NS_PER_S)
            self._command(now, self.side * cfg.max_steering, -cfg.min_speed)
            return
        if front < cfg.front_turn:
            steer_away += cfg.max_steering * 2.0 * (cfg.front_turn - front) / cfg.front_turn
        steering = _clip(-self.side * steer_away, -cfg.max_steering, cfg.max_steering)

        turn = abs(steering) / cfg.max_steering
        clear = _clip((front - cfg.front_min) / (cfg.front_slow - cfg.front_min), 0.0, 1.0)
        self._command(now, steering, cfg.min_speed + (cfg.speed - cfg.min_speed) * min(1.0 - turn, clear))

    def _command(self, now: int, steering: float, speed: float) -> None:
        self.bus.publish(
            self.topic,
            AckermannDriveStamped(Header.at(now, "base_link"), AckermannDrive(steering_angle=steering, speed=speed)),
        )
