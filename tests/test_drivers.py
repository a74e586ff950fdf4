"""Autonomous drivers: wall-follow laps the racecourse and holds 60 s in the tunnel, pure-pursuit laps a track,
each reading only /scan and /vesc/odom, and never touching a wall."""

from __future__ import annotations

import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from racecar_sim import Simulator
from racecar_sim.bus import Bus
from racecar_sim.core.errors import ConfigError
from racecar_sim.drivers import PurePursuit, WallFollower, load_waypoints, pure_pursuit_config, wall_follow_config
from racecar_sim.drivers.odom import planar_pose
from racecar_sim.msgs import AckermannDriveStamped, Header, LaserScan

NAVIGATION = "/vesc/ackermann_cmd_mux/input/navigation"


class Watch:
    """Follows a drive: the path from /vesc/odom, the shortest lidar range, and any car-wall contact."""

    def __init__(self, sim: Simulator) -> None:
        self.sim = sim
        self.xy: list[tuple[float, float]] = []
        self.yaw: list[float] = []
        self.min_range = math.inf
        self.wall_contacts = 0
        self._car = sim.model.body(sim.car.robot.root).id
        sim.subscribe("/vesc/odom", self._on_odom)
        sim.subscribe("/scan", self._on_scan)

    def _on_odom(self, msg) -> None:
        pose = planar_pose(msg)
        self.xy.append((pose.x, pose.y))
        self.yaw.append(pose.yaw)

    def _on_scan(self, msg: LaserScan) -> None:
        ranges = np.asarray(msg.ranges)
        self.min_range = min(self.min_range, float(np.min(ranges[np.isfinite(ranges)], initial=math.inf)))

    def check_contacts(self) -> None:
        """A contact between the car and the world with a near-horizontal normal is a wall (the ground's is
        vertical)."""
        model, data = self.sim.model, self.sim.data
        for c in data.contact[: data.ncon]:
            roots = model.body_rootid[model.geom_bodyid[[c.geom1, c.geom2]]]
            if (roots == self._car).sum() == 1 and abs(c.frame[2]) < 0.5:
                self.wall_contacts += 1

    def run(self, duration: float, until=lambda: False) -> None:
        while self.sim.time < duration and not until():
            self.sim.run_for(0.05)
            self.check_contacts()

    @property
    def turned(self) -> float:
        """Heading change since the start, unwrapped (rad, + anticlockwise)."""
        yaw = np.unwrap(self.yaw)
        return float(yaw[-1] - yaw[0]) if len(yaw) else 0.0

    @property
    def distance(self) -> float:
        xy = np.array(self.xy)
        return float(np.sum(np.hypot(*np.diff(xy, axis=0).T)))


@pytest.mark.parametrize("side", ["left", "right"])
def test_wall_follow_laps_the_walker_course(side):
    sim = Simulator(world="walker", camera=False)
    WallFollower(sim.bus, wall_follow_config(side=side))
    watch = Watch(sim)
    watch.run(150.0, until=lambda: watch.turned >= 2 * math.pi and math.dist(watch.xy[-1], watch.xy[0]) < 2.0)
    # a lap: the course turns anticlockwise once, and the car comes back past its start
    assert watch.turned >= 2 * math.pi and math.dist(watch.xy[-1], watch.xy[0]) < 2.0, (sim.time, watch.xy[-1])
    assert max(math.dist(p, watch.xy[0]) for p in watch.xy) > 20.0  # it went round, not in a circle at the start
    assert watch.distance > 90.0  # the course's centreline is about 100 m round
    assert watch.min_range > 0.15 and watch.wall_contacts == 0, (watch.min_range, watch.wall_contacts)


def test_wall_follow_drives_the_tunnel_for_60_s():
    sim = Simulator(world="tunnel", camera=False)
    WallFollower(sim.bus)
    watch = Watch(sim)
    watch.run(60.0)
    assert sim.time >= 60.0 and watch.distance > 50.0
    assert watch.min_range > 0.15 and watch.wall_contacts == 0, (watch.min_range, watch.wall_contacts)


def circle_track(folder: Path, radius: float = 6.0, points: int = 200) -> Path:
    angles = np.linspace(0.0, 2 * math.pi, points, endpoint=False)
    rows = ["# x_m, y_m, w_tr_right_m, w_tr_left_m"]
    rows += [f"{radius * math.cos(a):.9f}, {radius * math.sin(a):.9f}, 1.1, 1.1" for a in angles]
    path = folder / "circle.csv"
    path.write_text("\n".join(rows) + "\n")
    return path


def test_pure_pursuit_laps_a_centerline_track(tmp_path):
    track = circle_track(tmp_path)
    sim = Simulator(world=str(track), camera=False)
    driver = PurePursuit(sim.bus, load_waypoints(track), pure_pursuit_config(speed=2.0))
    watch = Watch(sim)
    watch.run(60.0, until=lambda: watch.turned >= 2 * math.pi)
    assert watch.turned >= 2 * math.pi and driver.laps == pytest.approx(1.0, abs=0.05)
    # 2 pi R / v = 18.85 s at 2 m/s, plus the start from rest
    assert 2 * math.pi * 6.0 / 2.0 < sim.time < 2 * math.pi * 6.0 / 2.0 * 1.15
    radii = np.hypot(*np.array(watch.xy).T)
    assert np.abs(radii - 6.0).max() < 0.35  # base_link stays on the centreline
    assert watch.min_range > 0.15 and watch.wall_contacts == 0


def test_pure_pursuit_stops_at_the_end_of_an_open_path(tmp_path):
    path = tmp_path / "waypoints.csv"
    path.write_text("# x, y, speed\n0, 0, 1.0\n4, 0, 1.0\n8, 2, 1.0\n10, 6, 1.0\n")
    sim = Simulator(world="empty", camera=False, lidar=False)
    waypoints = load_waypoints(path)
    assert not waypoints.closed and waypoints.speeds is not None
    PurePursuit(sim.bus, waypoints)
    watch = Watch(sim)
    watch.run(30.0)
    assert math.dist(watch.xy[-1], (10.0, 6.0)) < 0.4
    assert math.dist(watch.xy[-1], watch.xy[-20]) < 0.01  # stopped for the last second


# An F1TENTH raceline as f1tenth_racetracks' Austin/Austin_raceline.csv is laid out (its last row repeats the first),
# shrunk to a 6 m square loop.
RACELINE = """# 8288b625-90b8-4275-83ed-3842478966d0
# 603fd3987364b09f9aacb70d1ed12c268e24dd56
# s_m; x_m; y_m; psi_rad; kappa_radpm; vx_mps; ax_mps2
0.0000000;0.0000000;0.0000000;0.0000000;0.0000000;1.5000000;0.0000000
3.0000000;3.0000000;0.0000000;0.0000000;0.0000000;1.2000000;0.0000000
6.0000000;6.0000000;0.0000000;1.5707963;0.0000000;1.0000000;0.0000000
12.0000000;6.0000000;6.0000000;3.1415927;0.0000000;1.0000000;0.0000000
18.0000000;0.0000000;6.0000000;4.7123890;0.0000000;1.0000000;0.0000000
24.0000000;0.0000000;0.0000000;0.0000000;0.0000000;1.5000000;0.0000000
"""


def test_raceline_and_headed_csvs_are_paths(tmp_path):
    raceline = tmp_path / "Track_raceline.csv"
    raceline.write_text(RACELINE)
    waypoints = load_waypoints(raceline)  # x_m, y_m and vx_mps found by name among seven ;-separated columns
    np.testing.assert_array_equal(waypoints.points, [[0, 0], [3, 0], [6, 0], [6, 6], [0, 6]])
    np.testing.assert_array_equal(waypoints.speeds, [1.5, 1.2, 1.0, 1.0, 1.0])
    assert waypoints.closed
    for name, text in (
        ("plain.csv", "x,y,speed\n0,0,1\n4,0,2\n8,2,3\n"),
        ("renamed.csv", "# speed_mps, y_m, x_m\n1, 0, 0\n2, 0, 4\n3, 2, 8\n"),
        ("centerline.csv", "x_m, y_m, w_tr_right_m, w_tr_left_m\n0, 0, 1, 1\n4, 0, 1, 1\n8, 2, 1, 1\n"),
    ):
        (tmp_path / name).write_text(text)
        path = load_waypoints(tmp_path / name)
        np.testing.assert_array_equal(path.points, [[0, 0], [4, 0], [8, 2]])
        assert path.speeds is None if name == "centerline.csv" else path.speeds.tolist() == [1, 2, 3]
    (tmp_path / "bad.csv").write_text(RACELINE.replace("6.0000000;6.0000000;0.0000000", "6.0000000;6.0000000;zero"))
    with pytest.raises(ConfigError, match=r"bad\.csv: line 6: y: not a number: 'zero'"):
        load_waypoints(tmp_path / "bad.csv")


def test_cli_pure_pursuit_follows_a_raceline(tmp_path):
    (tmp_path / "Track_raceline.csv").write_text(RACELINE)
    result = subprocess.run(
        [
            sys.executable,
            "-m",
            "racecar_sim",
            "run",
            "--world",
            "empty",
            "--no-camera",
            "--no-record",
            "--no-summary",
            "--driver",
            "pure-pursuit",
            "--path",
            str(tmp_path / "Track_raceline.csv"),
            "--duration",
            "4",
            "--out",
            str(tmp_path),
        ],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert result.returncode == 0, result.stderr
    distance = float(next(line for line in result.stdout.splitlines() if line.startswith("distance")).split()[1])
    assert 3.0 < distance < 4 * 1.5  # at the raceline's speeds, 1.5 m/s at most


def synthetic_wall_scan(distance: float, approach: float, side: str, stamp_ns: int = 0) -> LaserScan:
    """A Hokuyo scan of one infinite straight wall `distance` m to one side, the car heading `approach` rad into it."""
    angles = -2.3561944902 + 0.0043633231 * np.arange(1081)
    sign = -1.0 if side == "right" else 1.0
    normal = sign * (math.pi / 2 - approach)  # direction of the wall's nearest point, in the laser frame
    cos = np.cos(angles - normal)
    ranges = np.where(cos > 1e-6, distance / np.maximum(cos, 1e-6), np.inf)
    ranges = np.where(ranges <= 10.0, ranges, np.inf).astype(np.float32)
    return LaserScan(
        Header.at(stamp_ns, "laser"),
        -2.3561944902,
        2.3561944902,
        0.0043633231,
        0.0,
        0.025,
        0.1,
        10.0,
        ranges,
        np.zeros(1081, np.float32),
    )


@pytest.mark.parametrize("side", ["left", "right"])
def test_wall_follow_steers_toward_a_far_wall_and_away_from_a_near_one(side):
    bus = Bus()
    commands: list[AckermannDriveStamped] = []
    bus.subscribe(NAVIGATION, commands.append)
    follower = WallFollower(bus, wall_follow_config(side=side, ki=0.0))
    toward = -1.0 if side == "right" else 1.0  # the sign of a steering angle that turns toward the wall
    bus.publish("/scan", synthetic_wall_scan(2.0, 0.0, side))
    assert commands[-1].drive.steering_angle * toward > 0.1
    bus.publish("/scan", synthetic_wall_scan(0.5, 0.0, side, 25_000_000))
    assert commands[-1].drive.steering_angle * toward < -0.1
    # parallel at the wanted distance: straight on, fast (the wall's far end inside the front cone slows it a little)
    bus.publish("/scan", synthetic_wall_scan(follower.config.distance, 0.0, side, 50_000_000))
    assert abs(commands[-1].drive.steering_angle) < 0.01
    assert commands[-1].drive.speed > (follower.config.speed + follower.config.min_speed) / 2


@pytest.mark.parametrize("approach", [-0.3, 0.0, 0.2, 0.4])
def test_wall_line_fit_recovers_the_wall_geometry(approach):
    follower = WallFollower(Bus(), wall_follow_config(side="right"))
    scan = synthetic_wall_scan(1.2, approach, "right")
    angles = scan.angle_min + scan.angle_increment * np.arange(1081)
    ranges = np.nan_to_num(np.asarray(scan.ranges, np.float64), posinf=10.0)
    measured_approach, distance = follower._wall(ranges, angles)
    assert measured_approach == pytest.approx(approach, abs=1e-3) and distance == pytest.approx(1.2, abs=1e-3)


def test_driver_settings_are_checked(tmp_path):
    with pytest.raises(ConfigError, match="side must be right or left"):
        wall_follow_config(side="middle")
    bad = tmp_path / "wall_follow.yaml"
    bad.write_text("side: left\ndistance: .nan\n")
    with pytest.raises(ConfigError, match=r"wall_follow.yaml: .*missing field"):
        wall_follow_config(bad)
    with pytest.raises(ConfigError, match="kp: expected a finite number"):
        wall_follow_config(kp=float("nan"))
    broken = tmp_path / "path.csv"
    broken.write_text("0, 0\n1, x\n")
    with pytest.raises(ConfigError, match="path.csv: line 2"):
        load_waypoints(broken)


def test_cli_driver_errors_are_one_line(tmp_path):
    for args, expected in (
        (["--driver", "pure-pursuit"], "needs --path"),
        (["--driver", "wall-follow", "--no-lidar"], "steers by the lidar"),
        (["--driver", "pure-pursuit", "--path", str(tmp_path / "none.csv")], "none.csv"),
    ):
        result = subprocess.run(
            [
                sys.executable,
                "-m",
                "racecar_sim",
                "run",
                "--world",
                "empty",
                "--no-camera",
                "--duration",
                "0.1",
                "--out",
                str(tmp_path),
                *args,
            ],
            capture_output=True,
            text=True,
            timeout=120,
        )
        assert result.returncode == 2 and len(result.stderr.strip().splitlines()) == 1, result.stderr
        assert expected in result.stderr


def test_planar_position_is_the_pose_and_heading_of_an_odometry_message() -> None:
    from racecar_sim.drivers.odom import planar_position
    from racecar_sim.msgs import Odometry, Point, Pose, PoseWithCovariance, Quaternion

    for yaw in (0.0, 0.7, -2.5, math.pi - 1e-9):
        # a rotation by `yaw` about z, then a pitch of 0.1 about the new y: the heading stays `yaw`
        cy, sy, cp, sp = math.cos(yaw / 2), math.sin(yaw / 2), math.cos(0.05), math.sin(0.05)
        q = Quaternion(x=-sy * sp, y=cy * sp, z=sy * cp, w=cy * cp)
        msg = Odometry(pose=PoseWithCovariance(Pose(Point(1.5, -2.0, 0.1), q)))
        x, y, heading = planar_position(msg)
        assert (x, y) == (1.5, -2.0)
        assert heading == pytest.approx(yaw, abs=1e-9)
        pose = planar_pose(msg)
        assert (pose.x, pose.y, pose.yaw) == (x, y, heading)
