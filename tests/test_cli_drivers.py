"""Your own driver from the CLI: `--driver file.py:Class` / `module:Class` (a node of the contract, built as
Class(ctx, **settings)), a driver per car of a fleet, `--driver-config FILE`; a bad spec is one line, exit code 2."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import pytest
from rosbags.highlevel import AnyReader

# A driver as a user writes it: commands a fixed speed and steering on the car's navigation input, from its scans.
DRIVER = """
from racecar_sim.msgs import AckermannDrive, AckermannDriveStamped, Header
from racecar_sim.nodes import NodeBase, NodeContext


class Circle(NodeBase):
    def __init__(self, ctx: NodeContext, speed: float = 1.0, steering: float = 0.3) -> None:
        self.bus, self.speed, self.steering = ctx.bus, speed, steering
        self.topic = ctx.topic("/vesc/ackermann_cmd_mux/input/navigation")
        self.frame = ctx.names.frame("base_link")
        ctx.timers.every(20.0, self.tick, "circle")

    def tick(self, now_ns: int) -> None:
        command = AckermannDrive(speed=self.speed, steering_angle=self.steering)
        self.bus.publish(self.topic, AckermannDriveStamped(Header.at(now_ns, self.frame), command))


class NotANode:
    def __init__(self, ctx) -> None:
        pass


def helper(ctx):
    return None
"""


@pytest.fixture
def driver_file(tmp_path: Path) -> Path:
    path = tmp_path / "my_driver.py"
    path.write_text(DRIVER)
    return path


def run(*args: str, cwd: Path | None = None) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "racecar_sim", "run", "--world", "empty", "--no-camera", *args],
        capture_output=True,
        text=True,
        timeout=300,
        cwd=cwd,
    )


def odometry(path: Path, topic: str) -> list[tuple[float, float]]:
    with AnyReader([path]) as reader:
        wanted = [c for c in reader.connections if c.topic == topic]
        rows = []
        for connection, _, raw in reader.messages(connections=wanted):
            position = reader.deserialize(raw, connection.msgtype).pose.pose.position
            rows.append((position.x, position.y))
    return rows


def circle_radius(path: list[tuple[float, float]]) -> float:
    """The radius of the circle through the path's start, a point a third of the way and its end."""
    (x1, y1), (x2, y2), (x3, y3) = path[0], path[len(path) // 3], path[-1]
    a, b, c = math.dist((x1, y1), (x2, y2)), math.dist((x2, y2), (x3, y3)), math.dist((x1, y1), (x3, y3))
    area = abs((x2 - x1) * (y3 - y1) - (x3 - x1) * (y2 - y1)) / 2
    return a * b * c / (4 * area)


def test_a_driver_file_drives_the_car_as_it_commands(driver_file, tmp_path):
    result = run("--driver", f"{driver_file}:Circle", "--duration", "4", "--out", str(tmp_path / "out"))
    assert result.returncode == 0, result.stderr
    assert result.stdout.startswith(f"world empty, driver {driver_file}:Circle")
    path = odometry(tmp_path / "out" / "run.mcap", "/vesc/odom")
    # 1 m/s at 0.3 rad: the seed profile's circle of radius wheelbase / tan(steering), turning left
    wheelbase = 0.325
    assert circle_radius(path[20:]) == pytest.approx(wheelbase / math.tan(0.3), rel=0.1)
    assert path[-1][1] > 0.5
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert summary["cars"]["racecar"]["driver"] == f"{driver_file}:Circle"
    assert summary["cars"]["racecar"]["distance"] == pytest.approx(3.6, abs=0.4)  # ~1 m/s once it is up to speed


def test_driver_config_gives_the_class_its_settings_and_a_module_name_imports(driver_file, tmp_path):
    (tmp_path / "slow.yaml").write_text("speed: 0.5\nsteering: 0.0\n")
    result = run(
        "--driver", "my_driver:Circle", "--driver-config", "slow.yaml", "--duration", "4", "--out", "out", cwd=tmp_path
    )
    assert result.returncode == 0, result.stderr
    path = odometry(tmp_path / "out" / "run.mcap", "/vesc/odom")
    assert abs(path[-1][1]) < 0.05 and 1.4 < path[-1][0] < 2.0  # straight, at half the speed


def test_two_cars_with_two_drivers_drive_two_different_paths(driver_file, tmp_path):
    (tmp_path / "right.yaml").write_text("steering: -0.3\n")
    result = run(
        "--cars", "2", "--driver", "constant", "--driver", f"car2={driver_file}:Circle",
        "--driver-config", f"car2={tmp_path / 'right.yaml'}", "--duration", "4", "--out", str(tmp_path / "out"),
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    assert f"driver car1 constant, car2 {driver_file}:Circle" in result.stdout.splitlines()[0]
    car1 = odometry(tmp_path / "out" / "run.mcap", "/car1/vesc/odom")
    car2 = odometry(tmp_path / "out" / "run.mcap", "/car2/vesc/odom")
    assert abs(car1[-1][1]) < 0.05 and car1[-1][0] > 2.5  # the constant command: straight ahead at 1 m/s
    assert car2[-1][1] < -0.5  # the file's driver: round to the right
    cars = json.loads((tmp_path / "out" / "summary.json").read_text())["cars"]
    assert (cars["car1"]["driver"], cars["car2"]["driver"]) == ("constant", f"{driver_file}:Circle")


def test_wall_follow_settings_from_a_yaml_file(tmp_path):
    (tmp_path / "far.yaml").write_text("distance: 1.1\nspeed: 1.0\n")
    result = subprocess.run(
        [sys.executable, "-m", "racecar_sim", "run", "--world", "walker", "--no-camera", "--duration", "10",
         "--driver-config", str(tmp_path / "far.yaml"), "--out", str(tmp_path / "out")],
        capture_output=True, text=True, timeout=300,
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())["cars"]["racecar"]
    assert summary["distance"] < 1.0 * 10 + 0.2  # no faster than the file's top speed (the default is 2.5 m/s)


@pytest.mark.parametrize(
    "options, message",
    [
        (["--driver", "nowhere.py:Gap"], "--driver nowhere.py:Gap: no such file nowhere.py"),
        (["--driver", "{file}:Missing"], "{file} has no Missing (it defines: Circle, NotANode)"),
        (["--driver", "{file}:NotANode"], "NotANode is not a node: it has no reset, rebind, close"),
        (["--driver", "{file}:helper"], "helper is a function, not a class"),
        (["--driver", "no_such_module_xyz:Gap"], "cannot import no_such_module_xyz (ModuleNotFoundError"),
        (["--driver", "{broken}:Gap"], "cannot be loaded (SyntaxError"),
        (["--driver", "teleport"], "'teleport' is not a driver"),
        (["--driver", "car1=constant"], "--driver car1=constant: cars are named only in a fleet: give --cars N"),
        (["--cars", "2", "--driver", "car3=constant"], "--driver car3=constant: the run has 2 cars (car1..car2)"),
        (["--driver", "constant", "--driver", "wall-follow"], "one --driver is for every car"),
        (["--driver-config", "{bad_field}"], "bad.yaml: unknown field 'sped' for wall-follow (it takes: side,"),
        (["--driver", "{file}:Circle", "--driver-config", "{bad_field}"],
         "bad.yaml: unknown field 'sped' for {file}:Circle (it takes: speed, steering)"),
        (["--driver-config", "{bad_value}"], "value.yaml: distance: expected a finite number, got 'far'"),
        (["--driver", "{file}:Circle", "--speed", "1"], "--speed does not apply to --driver {file}:Circle"),
    ],
)  # fmt: skip
def test_bad_driver_specs_are_one_line_and_exit_2(driver_file, tmp_path, options, message):
    (tmp_path / "broken.py").write_text("def oops(:\n")
    (tmp_path / "bad.yaml").write_text("sped: 1\n")
    (tmp_path / "value.yaml").write_text("distance: far\n")
    names = {"file": driver_file, "broken": tmp_path / "broken.py", "bad_field": tmp_path / "bad.yaml",
             "bad_value": tmp_path / "value.yaml"}  # fmt: skip
    result = run(*[o.format(**names) for o in options], "--duration", "1", "--no-record", cwd=tmp_path)
    assert result.returncode == 2, result.stdout + result.stderr
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("racecar-sim"), result.stderr
    assert message.format(**names) in lines[0]
    assert "Traceback" not in result.stderr


def test_the_readme_example_runs_from_the_cli(tmp_path):
    example = Path(__file__).resolve().parents[1] / "examples" / "follow_the_gap.py"
    result = subprocess.run(
        [sys.executable, "-m", "racecar_sim", "run", "--driver", f"{example}:FollowTheGap", "--no-camera",
         "--duration", "8", "--out", str(tmp_path)],
        capture_output=True, text=True, timeout=300,
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    car = json.loads((tmp_path / "summary.json").read_text())["cars"]["racecar"]
    assert car["distance"] > 5.0 and car["crash_count"] == 0  # off along walker's course, clear of its walls
