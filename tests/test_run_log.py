"""RunLog's memory stays flat in a long run: distance, mean speed and min clearance are running totals over every
message (the same figures as summing the whole path), and the path kept for summary.png is thinned to at most
TRAJECTORY_ROWS rows, its rate (trajectory_rate) halving each time, which the summary's 10 s marks follow."""

from __future__ import annotations

import itertools
import math
from types import SimpleNamespace

import numpy as np

from racecar_sim.bus import Bus
from racecar_sim.msgs import (
    Header,
    Odometry,
    Point,
    Pose,
    PoseWithCovariance,
    Quaternion,
    Twist,
    TwistWithCovariance,
    Vector3,
)
from racecar_sim.runtime.run_log import ODOMETRY_RATE, TRAJECTORY_ROWS, RunLog
from racecar_sim.worlds import load_world

PERIOD_NS = round(1e9 / ODOMETRY_RATE)


def drive(count: int) -> tuple[RunLog, list[tuple[float, float, float]]]:
    """A RunLog fed `count` odometry messages of a car circling at a changing speed; the rows it was sent."""
    bus = Bus()
    log = RunLog(bus, None, None, odom_topic="/vesc/odom")
    rows = []
    for i in range(count):
        a = 0.001 * i
        x, y, vx, vy = 5.0 * math.cos(a), 5.0 * math.sin(a), -math.sin(a) * (1 + 0.001 * (i % 500)), math.cos(a)
        bus.publish(
            "/vesc/odom",
            Odometry(
                Header.at(i * PERIOD_NS, "map"),
                "odom",
                PoseWithCovariance(Pose(Point(x, y, 0.0), Quaternion(0.0, 0.0, 0.0, 1.0))),
                TwistWithCovariance(Twist(Vector3(vx, vy, 0.0), Vector3())),
            ),
        )
        rows.append((x, y, math.hypot(vx, vy)))
    return log, rows


def test_a_long_run_keeps_a_bounded_path_and_the_exact_figures():
    count = 3 * TRAJECTORY_ROWS + 7  # the path fills up twice: every 4th message is kept
    log, rows = drive(count)
    distance = 0.0
    for (x0, y0, _), (x1, y1, _) in itertools.pairwise(rows):
        distance += math.hypot(x1 - x0, y1 - y0)
    assert log.distance == distance  # summed over every message, in order: the figure the whole path gave
    assert log.mean_speed == distance / ((count - 1) * PERIOD_NS / 1e9)
    traj = log.trajectory
    assert len(traj) <= TRAJECTORY_ROWS + 1
    assert log.trajectory_rate == ODOMETRY_RATE / 4
    np.testing.assert_array_equal(traj[:-1], np.array(rows[::4]))
    np.testing.assert_array_equal(traj[-1], rows[-1])  # the path ends where the car did


def test_a_short_run_keeps_every_row():
    log, rows = drive(1200)  # the main job's 60 s
    np.testing.assert_array_equal(log.trajectory, np.array(rows))
    assert log.trajectory_rate == ODOMETRY_RATE


def test_the_summary_marks_every_10_s_of_a_thinned_path():
    from racecar_sim.plots.summary import summary_figure

    count = TRAJECTORY_ROWS + 1  # 819.2 s: every other message kept
    log, _ = drive(count)
    _, ax = summary_figure(load_world("empty"), log.trajectory, rate=log.trajectory_rate)
    marks = [text.get_text() for text in ax.texts if text.get_text().endswith(" s")]
    # 2.6 turns of one circle: the marks of later turns that would cover earlier ones are left out, the others are
    # at the sim times a 10 s spacing of the thinned rows gives (a wrong rate would put marks at 5 s or from 20 s)
    assert marks[:3] == ["10 s", "20 s", "30 s"] and len(marks) >= 20
    assert set(marks) <= {f"{t} s" for t in range(10, 819, 10)}


def test_min_clearance_is_the_shortest_finite_range_whatever_else_the_scan_holds():
    """inf (no echo), NaN and -inf are not ranges: the clearance is the least finite one, over every scan."""
    log = RunLog(Bus(), "/scan", None, "/odom")
    scans = [
        [np.inf, 3.0, 2.5, np.inf],
        [np.nan, 4.0, 1.75, -np.inf],  # 1.75: NaN and -inf skipped, not taken as the minimum
        [np.inf, np.inf],  # no echo at all: nothing changes
        [],
        [2.0, np.nan],
    ]
    expected = math.inf
    for ranges in scans:
        log._on_scan(SimpleNamespace(ranges=np.array(ranges, np.float32)))
        finite = [r for r in ranges if math.isfinite(r)]
        expected = min([expected, *finite])
        assert log.min_clearance == expected
    assert log.min_clearance == 1.75


def test_min_clearance_is_numpys_minimum_of_the_finite_ranges_over_random_scans() -> None:
    """Scans of float32 and float64 ranges, with no echoes, NaN, -inf and signed zeros among them: the clearance is
    numpy's minimum of the finite ones, bit for bit (the sign of a zero too), over every scan so far."""
    rng = np.random.default_rng(7)
    for dtype in (np.float32, np.float64):
        log = RunLog(Bus(), "/scan", None, "/odom")
        expected = np.inf
        for _ in range(300):
            ranges = rng.uniform(0.5, 30.0, int(rng.integers(1, 40))).astype(dtype)
            picks = rng.random(len(ranges))
            ranges[picks < 0.3] = np.inf
            ranges[(picks > 0.95)] = rng.choice([np.nan, -np.inf, 0.0, -0.0])
            log._on_scan(SimpleNamespace(ranges=ranges))
            finite = ranges[np.isfinite(ranges)]
            if len(finite) and finite.min() < expected:
                expected = finite.min()
            assert np.float64(log.min_clearance).tobytes() == np.float64(expected).tobytes()
        assert log.min_clearance == 0.0  # a zero range came up
