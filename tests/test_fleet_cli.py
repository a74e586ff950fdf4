"""`racecar-sim run --cars N` (issue 11): car1..carN in a row behind the spawn pose (or along a track's centerline),
each with its own driver; the MCAP holds every car's topics, summary.png every car's path in its own colour,
Foxglove every car's frames, and the viewer follows one car at a time."""

from __future__ import annotations

import math
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from PIL import Image
from rosbags.highlevel import AnyReader
from rosbags.typesys import Stores, get_typestore

from racecar_sim import Car, Simulator, Spawn
from racecar_sim.bridges.foxglove.bridge import FoxgloveBridge
from racecar_sim.cli.run import fleet_spawns
from racecar_sim.plots.summary import DPI, FIGSIZE, SIDE, WIDE, fleet_color, save_summary, summary_figure
from racecar_sim.worlds import load_world
from test_foxglove import SLICE, FoxgloveClient, until
from test_viewer import display, find_window, hold, needs_x, x_env, xdotool  # noqa: F401 (display: a fixture)

CLI = [sys.executable, "-m", "racecar_sim"]
QUIET = ["--no-camera", "--no-summary"]
STILL = ["--driver", "constant", "--speed", "0"]  # cars that stay where they were put
R = 6.0  # m, radius of the circle track


def run_cli(*args: str, timeout: float = 180, **kwargs) -> subprocess.CompletedProcess:
    return subprocess.run([*CLI, "run", *args], capture_output=True, text=True, timeout=timeout, **kwargs)


def read_bag(path: Path) -> tuple[dict[str, int], dict[str, list]]:
    """Message counts per topic, and every odometry message per /…/vesc/odom topic."""
    with AnyReader([path], default_typestore=get_typestore(Stores.EMPTY)) as reader:
        counts = {c.topic: c.msgcount for c in reader.connections}
        odom: dict[str, list] = {}
        wanted = [c for c in reader.connections if c.topic.endswith("/vesc/odom")]
        for connection, _, raw in reader.messages(connections=wanted):
            odom.setdefault(connection.topic, []).append(reader.deserialize(raw, connection.msgtype))
    return counts, odom


def first_pose(odom: list) -> tuple[float, float, float]:
    pose = odom[0].pose.pose
    q = pose.orientation
    return pose.position.x, pose.position.y, math.atan2(2 * (q.w * q.z + q.x * q.y), 1 - 2 * (q.y * q.y + q.z * q.z))


def colour_pixels(rgb: np.ndarray, colour: str, box: tuple[float, float, float, float], tol: int = 8) -> int:
    """How many pixels within `tol` of a '#rrggbb' colour lie in `box` (figure fractions: left, bottom, w, h)."""
    target = np.array([int(colour[i : i + 2], 16) for i in (1, 3, 5)])
    height, width = rgb.shape[:2]
    left, bottom, w, h = box
    rows = slice(round((1 - bottom - h) * height), round((1 - bottom) * height))
    part = rgb[rows, round(left * width) : round((left + w) * width)]
    return int((np.abs(part - target).max(axis=2) <= tol).sum())


def circle_track(folder: Path) -> Path:
    """An anticlockwise circle of radius R about the origin, 2 m wide, starting at (R, 0)."""
    angles = np.linspace(0.0, 2 * math.pi, 120, endpoint=False)
    path = folder / "circle.csv"
    path.write_text(
        "# x_m, y_m, w_tr_right_m, w_tr_left_m\n"
        + "".join(f"{R * math.cos(a):.9f}, {R * math.sin(a):.9f}, 1.0, 1.0\n" for a in angles)
    )
    return path


def test_three_cars_in_the_tunnel_record_every_cars_topics_and_draw_every_path(tmp_path):
    record = tmp_path / "fleet.mcap"
    result = run_cli(
        "--world",
        "tunnel",
        "--cars",
        "3",
        "--no-camera",
        "--duration",
        "3",
        "--record",
        str(record),
        "--out",
        str(tmp_path),
    )
    assert result.returncode == 0, result.stderr
    counts, odom = read_bag(record)
    for k in (1, 2, 3):
        assert counts[f"/car{k}/scan"] == 120  # 40 Hz x 3 s
        assert counts[f"/car{k}/vesc/odom"] == 60  # 20 Hz x 3 s
        assert counts[f"/car{k}/vesc/ackermann_cmd_mux/input/navigation"] > 50  # its own wall-follower
    assert "/scan" not in counts and "/vesc/odom" not in counts
    # In a row along the spawn heading (+x in the tunnel), 1.5 m apart, all facing the same way.
    starts = [first_pose(odom[f"/car{k}/vesc/odom"]) for k in (1, 2, 3)]
    for k, (x, y, yaw) in enumerate(starts):
        assert x == pytest.approx(-1.5 * k, abs=0.02) and y == pytest.approx(0.0, abs=0.02)
        assert yaw == pytest.approx(0.0, abs=0.02)
    # The summary: a row per car, and each car's own path colour on the map (the tunnel takes the WIDE layout).
    lines = result.stdout.splitlines()
    assert lines[1].startswith("cars             3 (car1..car3), 1.5 m apart")
    for k in (1, 2, 3):
        row = next(line for line in lines if line.startswith(f"car{k} "))
        assert float(row.split()[1]) > 1.0  # metres driven
    with Image.open(tmp_path / "summary.png") as image:
        assert image.size == (round(FIGSIZE[0] * DPI), round(FIGSIZE[1] * DPI))
        rgb = np.asarray(image.convert("RGB")).astype(int)
    # the map takes the height the panel below it leaves; right of the legend (which shows each colour too)
    right_of_legend = (0.3, 0.03, WIDE.map[0] + WIDE.map[2] - 0.3, WIDE.map[1] + WIDE.map[3] - 0.03)
    for k in range(3):
        assert colour_pixels(rgb, fleet_color(k), right_of_legend) > 50, f"car{k + 1}'s path is not on the map"


def test_car_spacing_sets_the_gap(tmp_path):
    record = tmp_path / "gap.mcap"
    result = run_cli(
        "--world",
        "empty",
        "--cars",
        "3",
        "--car-spacing",
        "2.0",
        *STILL,
        *QUIET,
        "--duration",
        "0.2",
        "--record",
        str(record),
        "--out",
        str(tmp_path),
    )
    assert result.returncode == 0, result.stderr
    _, odom = read_bag(record)
    xs = [first_pose(odom[f"/car{k}/vesc/odom"])[0] for k in (1, 2, 3)]
    assert xs == pytest.approx([0.0, -2.0, -4.0], abs=0.02)


def test_a_track_csv_lines_the_cars_up_along_its_centerline(tmp_path):
    track = circle_track(tmp_path)
    record = tmp_path / "track.mcap"
    result = run_cli(
        "--world",
        str(track),
        "--cars",
        "4",
        *STILL,
        *QUIET,
        "--duration",
        "0.2",
        "--record",
        str(record),
        "--out",
        str(tmp_path),
    )
    assert result.returncode == 0, result.stderr
    _, odom = read_bag(record)
    starts = np.array([first_pose(odom[f"/car{k}/vesc/odom"]) for k in (1, 2, 3, 4)])
    angles = np.arctan2(starts[:, 1], starts[:, 0])
    assert np.hypot(starts[:, 0], starts[:, 1]) == pytest.approx(R, abs=0.03)  # on the centerline
    # each one 1.5 m of track behind the one before (clockwise: the track runs anticlockwise)
    assert np.diff(np.unwrap(angles)) * R == pytest.approx(-1.5, abs=0.02)
    # facing along the track (the tangent of an anticlockwise circle)
    heading = np.angle(np.exp(1j * (starts[:, 2] - angles - math.pi / 2)))
    assert np.all(np.abs(heading) < 0.05), heading


def test_fleet_spawns_walk_back_along_a_polyline():
    world = load_world("empty")
    square = np.array([[0.0, 0.0], [10.0, 0.0], [10.0, 10.0], [0.0, 10.0]])
    world.spawn = Spawn(0.0, 0.0, 0.05, 0.0)
    spawns = fleet_spawns(world, 4, 4.0, square)
    # back from (0, 0) along the last side (0, 10) -> (0, 0), then round the corner onto (10, 10) -> (0, 10)
    np.testing.assert_allclose([(s.x, s.y) for s in spawns], [(0, 0), (0, 4), (0, 8), (2, 10)], atol=1e-12)
    assert [s.yaw for s in spawns] == pytest.approx([0.0, -math.pi / 2, -math.pi / 2, math.pi])
    assert {s.z for s in spawns} == {0.05}
    world.spawn = Spawn(1.0, 2.0, 0.1, math.pi / 2)  # no centerline: straight back along the heading
    np.testing.assert_allclose(
        [(s.x, s.y, s.z, s.yaw) for s in fleet_spawns(world, 3, 1.5)],
        [(1, 2, 0.1, math.pi / 2), (1, 0.5, 0.1, math.pi / 2), (1, -1, 0.1, math.pi / 2)],
        atol=1e-12,
    )


@pytest.mark.parametrize(
    "options, message",
    [
        # walker's course bends 7 m behind the start line: car2 8 m back is in the bend's wall ...
        (
            ["--cars", "2", "--car-spacing", "8"],
            "car2's spawn pose (-8, 0, 0.05, 0) is inside an obstacle: the car's "
            "left_front_wheel_collision is 0.11 m into walker_racecourse::",
        ),
        # ... and car7 9 m back is past it, on the infield's floor but on the far side of the wall from car6
        (
            ["--cars", "8"],
            "car7's spawn pose (-9, 0, 0.05, 0) is on the far side of walker_racecourse::wall_left_8/"
            "collision from car6",
        ),
    ],
)
def test_a_car_put_into_or_behind_a_wall_is_one_line_naming_it(tmp_path, options, message):
    result = run_cli("--world", "walker", *options, *QUIET, "--duration", "1", "--no-record", "--out", str(tmp_path))
    assert result.returncode == 2
    assert "Traceback" not in result.stderr
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1, lines
    # checked before the cars are built: the message names the options and how many cars fit
    assert lines[0].startswith("racecar-sim: error: --cars ") and message in lines[0]
    assert "walker (racecar_walker.world): " in lines[0] and " in a row at " in lines[0]
    assert not (tmp_path / "summary.png").exists()


def test_eight_cars_fit_in_the_tunnel(tmp_path):
    result = run_cli(
        "--world", "tunnel", "--cars", "8", *QUIET, "--duration", "0.5", "--no-record", "--out", str(tmp_path)
    )
    assert result.returncode == 0, result.stderr
    assert [line.split()[0] for line in result.stdout.splitlines() if line.startswith("car") and "m/s" in line] == [
        f"car{k}" for k in range(1, 9)
    ]


def test_without_cars_the_names_and_summary_are_the_originals(tmp_path):
    record = tmp_path / "one.mcap"
    result = run_cli(
        "--world",
        "empty",
        "--driver",
        "constant",
        *QUIET,
        "--duration",
        "1",
        "--record",
        str(record),
        "--out",
        str(tmp_path),
    )
    assert result.returncode == 0, result.stderr
    counts, _ = read_bag(record)
    assert counts["/scan"] == 40 and counts["/vesc/odom"] == 20
    assert not any(topic.startswith("/car") for topic in counts)
    starts = [line.split()[0] for line in result.stdout.splitlines()]
    assert starts == ["world", "sim", "distance", "mean", "real-time", "min", "laps", "crashes", "final", "wrote"]
    spacing = run_cli("--world", "empty", "--car-spacing", "2", *QUIET, "--duration", "1", "--no-record")
    assert spacing.returncode == 2
    assert spacing.stderr.strip() == "racecar-sim: error: --car-spacing places a fleet: give --cars N too"


def test_fleet_summary_has_a_colour_and_a_legend_entry_per_car(tmp_path):
    walker = load_world("walker")
    t = np.linspace(0.0, 1.0, 200)[:, None]
    paths = {f"car{k + 1}": np.hstack([np.c_[-1.5 * k + 6 * t, 3 * k * t], np.ones_like(t)]) for k in range(3)}
    path = save_summary(tmp_path / "summary.png", walker, paths, lines=["car1 ..."])
    with Image.open(path) as image:
        rgb = np.asarray(image.convert("RGB")).astype(int)
    for k in range(3):
        assert colour_pixels(rgb, fleet_color(k), SIDE.map) > 300  # a path 6 m and more long, 3 pt wide
    fig, _ = summary_figure(walker, paths)
    labels = [text.get_text() for legend in fig.legends for text in legend.get_texts()]
    assert labels[:3] == ["car1", "car2", "car3"]
    assert len(fig.axes) == 1  # no speed colour bar: colour means the car here
    one, _ = summary_figure(walker, {"car1": paths["car1"]})  # one car: the single car's picture
    assert len(one.axes) == 2


def test_foxglove_serves_every_cars_topics_and_frames():
    cars = [Car("car1", camera=False), Car("car2", spawn=Spawn(-1.5, 0.0, 0.05, 0.0), camera=False)]
    sim = Simulator(world="tunnel", cars=cars)
    bridge = FoxgloveBridge(sim.bus, lambda: sim.time_ns, port=0)

    def step() -> None:
        sim.run_for(SLICE)
        client.poll()

    try:
        with FoxgloveClient(bridge.port) as client:
            wanted = ("/car1/scan", "/car2/scan", "/car2/vesc/odom", "/tf", "/tf_static")
            until(lambda: all(t in client.channels for t in wanted), step, f"{wanted} to be advertised")
            client.subscribe("/car2/scan", "/tf", "/tf_static")
            until(lambda: all(client.messages[t] for t in ("/car2/scan", "/tf", "/tf_static")), step, "messages")
            typestore = get_typestore(Stores.ROS2_HUMBLE)
            scan = typestore.deserialize_cdr(client.messages["/car2/scan"][0][1], "sensor_msgs/msg/LaserScan")
            assert scan.header.frame_id == "car2/laser"
            static = typestore.deserialize_cdr(client.messages["/tf_static"][-1][1], "tf2_msgs/msg/TFMessage")
            frames = {(t.header.frame_id, t.child_frame_id) for t in static.transforms}
            assert {
                ("car1/base_link", "car1/chassis"),
                ("car2/base_link", "car2/chassis"),
                ("car2/chassis", "car2/laser"),
            } <= frames
            until(lambda: len(client.messages["/tf"]) > 20, step, "a second of /tf")
            moving = {
                t.child_frame_id
                for _, raw in client.messages["/tf"]
                for t in typestore.deserialize_cdr(raw, "tf2_msgs/msg/TFMessage").transforms
            }
            assert {"car1/left_front_wheel", "car2/left_front_wheel", "car2/odom"} <= moving
    finally:
        bridge.close()
        sim.close()


@needs_x
def test_the_viewer_follows_the_next_car_and_wasd_drives_it(display, tmp_path):  # noqa: F811 (the fixture)
    record, stderr = tmp_path / "viewer.mcap", tmp_path / "stderr.txt"
    with stderr.open("w") as err:
        proc = subprocess.Popen(
            [
                *CLI,
                "run",
                "--world",
                "empty",
                "--cars",
                "2",
                "--car-spacing",
                "3",
                *STILL,
                "--viewer",
                *QUIET,
                "--duration",
                "12",
                "--record",
                str(record),
                "--out",
                str(tmp_path),
            ],
            env=x_env(display),
            stdin=subprocess.DEVNULL,
            stdout=subprocess.DEVNULL,
            stderr=err,
        )
        try:
            window = find_window(display, proc, stderr)
            time.sleep(1.0)
            assert xdotool(display, "key", "--window", window, "period").returncode == 0
            deadline = time.monotonic() + 30
            while "following car2" not in stderr.read_text():
                assert time.monotonic() < deadline and proc.poll() is None, stderr.read_text()
                time.sleep(0.2)
            hold(display, window, "w", 3.0)
            assert proc.wait(timeout=120) == 0, stderr.read_text()
        finally:
            if proc.poll() is None:
                proc.kill()
                proc.wait()
    _, odom = read_bag(record)
    car1 = odom["/car1/vesc/odom"][-1].pose.pose.position
    car2 = odom["/car2/vesc/odom"][-1].pose.pose.position
    assert abs(car1.x) < 0.05, "car1 moved: the keys drove the car no longer followed"
    assert -3.0 + 0.5 < car2.x < -0.5, "car2 did not drive forward on w (or it drove into car1)"
