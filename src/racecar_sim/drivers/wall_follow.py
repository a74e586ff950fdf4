"""wall-follow: hold a distance to the right or left wall with a PID on the lidar, as in the F1TENTH lab."""

from __future__ import annotations

import math

import numpy as np

from racecar_sim.bus import Bus
from racecar_sim.core.time import NS_PER_S
from racecar_sim.drivers.config import WallFollowConfig, wall_follow_config
from racecar_sim.drivers.constant import NAVIGATION
from racecar_sim.drivers.odom import planar_pose
from racecar_sim.msgs import AckermannDrive, AckermannDriveStamped, Header, LaserScan, Odometry



class WallFollower:
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

    def __init__(self, bus: Bus, config: WallFollowConfig | None = None, topic: str = NAVIGATION,
                 scan_topic: str = "/scan", odom_topic: str = "/vesc/odom") -> None:
        self.config = config or wall_follow_config()
        self.bus, self.topic = bus, topic
        self.side = -1.0 if self.config.side == "right" else 1.0  # the wall's side as a sign of the beam angle
        self.speed = 0.0
        self.error = 0.0
        self._integral = 0.0
        self._last_ns: int | None = None
        self._range_max = 10.0
        self._reverse_until = -1
        bus.subscribe(odom_topic, self._on_odom)
        bus.subscribe(scan_topic, self._on_scan)

    def _on_odom(self, msg: Odometry) -> None:
        self.speed = planar_pose(msg).speed

    def _wall(self, ranges: np.ndarray, angles: np.ndarray) -> tuple[float, float]:
        """The approach angle (rad, > 0 heading into it) and distance (m) of the wall on the followed side.

        The wall is a line fitted to the beam ends within `patch` of the nearest one in the side sector:
        along a straight wall that is the wall; at a wall's end it is the corner, which the car then rounds
        at `distance`, because the fitted line turns with the bearing of the nearest point.
        """
        cfg = self.config
        bearing = self.side * angles
        sector = (bearing >= math.radians(cfg.sector[0])) & (bearing <= math.radians(cfg.sector[1]))
        points = np.stack([ranges[sector] * np.cos(angles[sector]), ranges[sector] * np.sin(angles[sector])], axis=1)
        points = points[ranges[sector] < self._range_max]
        if len(points) < 2:
            return 0.0, self._range_max
        nearest = points[np.argmin(np.einsum("ij,ij->i", points, points))]
        patch = points[np.hypot(*(points - nearest).T) <= cfg.patch]
        if len(patch) < 2:
            return 0.0, float(np.hypot(*nearest))
        centre = patch.mean(axis=0)
        along = np.linalg.svd(patch - centre, full_matrices=False)[2][0]
        if along[0] < 0:
            along = -along
        # turning into the wall rotates it, seen from the car, against the wall's side
        approach = -self.side * math.atan2(along[1], along[0])
        return approach, abs(float(centre[0] * along[1] - centre[1] * along[0]))

    def _on_scan(self, scan: LaserScan) -> None:
        cfg = self.config
        self._range_max = scan.range_max
        ranges = np.nan_to_num(np.asarray(scan.ranges, np.float64), posinf=scan.range_max, neginf=scan.range_max)
        angles = scan.angle_min + scan.angle_increment * np.arange(len(ranges))
        approach, wall = self._wall(ranges, angles)
        ahead = cfg.lookahead + cfg.lookahead_time * max(self.speed, 0.0)
        distance = wall - ahead * math.sin(approach)
        error = distance - cfg.distance  # > 0: too far from the wall

        now = scan.header.stamp.to_ns()
        dt = 0.0 if self._last_ns is None else (now - self._last_ns) / NS_PER_S
        self._last_ns, self.error = now, error
        if cfg.ki:
            limit = cfg.max_approach / cfg.ki
            self._integral = float(np.clip(self._integral + error * dt, -limit, limit))
        wanted = float(np.clip(cfg.kp * error + cfg.ki * self._integral, -cfg.max_approach, cfg.max_approach))
        steer_away = cfg.kd * (approach - wanted)

        front = float(np.min(ranges[np.abs(angles) <= math.radians(cfg.front_cone)], initial=scan.range_max))
        if front < cfg.stuck or now < self._reverse_until:
            # boxed in (an acute pocket, a dead end too tight to turn in): back out, swinging the nose away
            if now >= self._reverse_until:
                self._reverse_until = now + int(cfg.reverse_time * NS_PER_S)
            self._command(now, self.side * cfg.max_steering, -cfg.min_speed)
            return
        if front < cfg.front_turn:
            steer_away += cfg.max_steering * 2.0 * (cfg.front_turn - front) / cfg.front_turn
        steering = float(np.clip(-self.side * steer_away, -cfg.max_steering, cfg.max_steering))

        turn = abs(steering) / cfg.max_steering
        clear = float(np.clip((front - cfg.front_min) / (cfg.front_slow - cfg.front_min), 0.0, 1.0))
        self._command(now, steering, cfg.min_speed + (cfg.speed - cfg.min_speed) * min(1.0 - turn, clear))

    def _command(self, now: int, steering: float, speed: float) -> None:
        self.bus.publish(self.topic, AckermannDriveStamped(Header.at(now, "base_link"),
                                                          AckermannDrive(steering_angle=steering, speed=speed)))
