"""Race results in every run folder: laps timed on the start line, crashes into walls and cars, in the printed summary,
summary.json and summary.png, checked against what the recording itself says (the odometry's crossing of the start
line, the time of the /racecar_sim/collisions message)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from PIL import Image
from rosbags.highlevel import AnyReader

from racecar_sim.plots.summary import CRASH_COLOR, LAP_COLOR

# walker's start line, from the checkered strip of its SDF (worlds/data/walker.world): x = 1.96 m, y in [-0.75, 1.35]
LINE_X, LINE_Y = 1.96, (-0.75, 1.35)
CAR_KEYS = {"driver", "distance", "mean_speed", "min_clearance", "final_pose", "laps", "lap_times", "best_lap",
            "crash_count", "crashes"}  # fmt: skip


def run(*args: str, cwd: Path | None = None) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "racecar_sim", "run", *args], capture_output=True, text=True, timeout=600, cwd=cwd
    )


def messages(path: Path, topic: str) -> list[tuple[float, object]]:
    with AnyReader([path]) as reader:
        wanted = [c for c in reader.connections if c.topic == topic]
        return [(t * 1e-9, reader.deserialize(raw, c.msgtype)) for c, t, raw in reader.messages(connections=wanted)]


def crossings(odom: list[tuple[float, object]]) -> list[float]:
    """Sim times the odometry's path crosses walker's start line going +x, interpolated between two messages."""
    times = []
    for (_, a), (_, b) in zip(odom, odom[1:]):
        pa, pb = a.pose.pose.position, b.pose.pose.position
        if pa.x < LINE_X <= pb.x:
            f = (LINE_X - pa.x) / (pb.x - pa.x)
            y = pa.y + f * (pb.y - pa.y)
            if LINE_Y[0] <= y <= LINE_Y[1]:
                ta, tb = (m.header.stamp.sec + m.header.stamp.nanosec * 1e-9 for m in (a, b))
                times.append(ta + f * (tb - ta))
    return times


def test_wall_follow_laps_walker_once_timed_as_the_odometry_crosses_the_line(tmp_path):
    result = run("--duration", "70", "--no-camera", "--out", str(tmp_path))
    assert result.returncode == 0, result.stderr
    crossed = crossings(messages(tmp_path / "run.mcap", "/vesc/odom"))
    assert len(crossed) == 2, crossed  # the start (the car spawns behind the line) and the end of the lap
    expected = crossed[1] - crossed[0]
    summary = json.loads((tmp_path / "summary.json").read_text())
    car = summary["cars"]["racecar"]
    assert car["laps"] == 1 and len(car["lap_times"]) == 1
    assert car["lap_times"][0] == pytest.approx(expected, abs=0.1) and car["best_lap"] == car["lap_times"][0]
    assert summary["start_line"] == [[pytest.approx(LINE_X), pytest.approx(LINE_Y[0])],
                                     [pytest.approx(LINE_X), pytest.approx(LINE_Y[1])]]  # fmt: skip
    laps = messages(tmp_path / "run.mcap", "/racecar_sim/lap")
    assert len(laps) == 1 and laps[0][1].data.split()[:2] == ["racecar", "1"]
    assert float(laps[0][1].data.split()[2]) == pytest.approx(car["lap_times"][0], abs=1e-3)
    assert f"laps             1: {car['lap_times'][0]:.2f} s (best {car['best_lap']:.2f} s)" in result.stdout
    # the lap's end is marked on the map with a gold diamond
    rgb = np.asarray(Image.open(tmp_path / "summary.png").convert("RGB")).astype(int)
    gold = np.array([int(LAP_COLOR[i : i + 2], 16) for i in (1, 3, 5)])
    assert (np.abs(rgb - gold).max(axis=2) < 10).sum() > 30


def test_the_readme_constant_steering_run_reports_its_crash_when_the_recording_has_it(tmp_path):
    result = run("--driver", "constant", "--speed", "1", "--steering", "0.2", "--duration", "5", cwd=tmp_path)
    assert result.returncode == 0, result.stderr
    (folder,) = (tmp_path / "runs").iterdir()
    recorded = messages(folder / "run.mcap", "/racecar_sim/collisions")
    assert len(recorded) == 1
    when, message = recorded[0]
    car, what = message.data.split(" ", 1)
    assert car == "racecar" and what.startswith("walker_racecourse::")
    summary = json.loads((folder / "summary.json").read_text())
    crashes = summary["cars"]["racecar"]["crashes"]
    assert summary["cars"]["racecar"]["crash_count"] == 1
    assert crashes == [{"time": pytest.approx(when, abs=1e-9), "what": what, "kind": "wall"}]
    assert 2.0 < when < 3.0  # it reaches walker's wall about 2.5 s in
    assert f"crashes          1: {when:.2f} s {what}" in result.stdout.splitlines()
    assert summary["world"] == "walker" and summary["driver"] == "constant" and summary["seed"] == 0
    assert summary["duration"] == pytest.approx(5.0)
    assert set(summary["cars"]["racecar"]) == CAR_KEYS
    # the crash is marked on the map with a red cross
    rgb = np.asarray(Image.open(folder / "summary.png").convert("RGB")).astype(int)
    red = np.array([int(CRASH_COLOR[i : i + 2], 16) for i in (1, 3, 5)])
    assert (np.abs(rgb - red).max(axis=2) < 10).sum() > 30


def test_two_cars_driven_into_each_other_report_one_car_car_crash_naming_both(tmp_path):
    (tmp_path / "stand.yaml").write_text("speed: 0\n")
    (tmp_path / "ram.yaml").write_text("speed: 1.0\n")
    result = run(
        "--world", "empty", "--cars", "2", "--driver", "constant", "--driver-config", f"car1={tmp_path / 'stand.yaml'}",
        "--driver-config", f"car2={tmp_path / 'ram.yaml'}", "--duration", "2.5", "--no-camera", "--out", str(tmp_path),
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    recorded = messages(tmp_path / "run.mcap", "/racecar_sim/collisions")
    assert [m.data for _, m in recorded] == ["car1 car2"]
    when = recorded[0][0]
    cars = json.loads((tmp_path / "summary.json").read_text())["cars"]
    assert cars["car1"]["crashes"] == [{"time": pytest.approx(when), "what": "car2", "kind": "car"}]
    assert cars["car2"]["crashes"] == [{"time": pytest.approx(when), "what": "car1", "kind": "car"}]
    # car2 starts 1.5 m behind car1 (bumpers ~1 m apart) and drives at 1 m/s: it touches about 1 s in
    assert 0.7 < when < 1.6
    assert cars["car1"]["driver"] == "constant" and cars["car2"]["distance"] > cars["car1"]["distance"]
    lines = result.stdout.splitlines()
    assert f"car1 crashes     1: {when:.2f} s car2" in lines and f"car2 crashes     1: {when:.2f} s car1" in lines


def test_start_line_option_counts_laps_where_it_says(tmp_path):
    # a circle of radius ~1.05 m round (0, 1.05) from the spawn, facing +x: a line across its bottom, crossed
    # forward (along the spawn heading) once a lap
    result = run(
        "--world", "empty", "--driver", "constant", "--speed", "1", "--steering", "0.3", "--duration", "16",
        "--start-line", "0.5,-0.5,0.5,0.6", "--no-camera", "--out", str(tmp_path),
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    car = json.loads((tmp_path / "summary.json").read_text())["cars"]["racecar"]
    # a lap of the circle is 2 pi r = 6.6 m at 1 m/s: 2 laps after the first crossing (~0.6 s)
    assert car["laps"] == 2 and car["lap_times"] == [pytest.approx(6.6, rel=0.1)] * 2
    bad = run("--start-line", "1,2,3", "--duration", "1")
    assert bad.returncode == 2 and bad.stderr.strip().count("\n") == 0 and "--start-line" in bad.stderr
    assert "x1,y1,x2,y2" in bad.stderr
