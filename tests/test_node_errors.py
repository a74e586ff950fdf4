"""A user's node that raises stops the run at that event and says so in one line: the node, its car, the exception and
the sim time, then the node's own frames only. The run's files are kept: the MCAP closed and readable, summary.json
and summary.png written up to then, marked as ended by the error; the exit code is NodeError.EXIT_CODE (3)."""

from __future__ import annotations

import json
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from racecar_sim import Simulator
from racecar_sim.core.errors import NodeError
from racecar_sim.nodes import NodeBase

CRASH_NS = 2_500_000_000  # the crash: the scan at 2.5 s (the 100th: 40 Hz from 0.025 s)

# A driver as a user writes one (README, Your own driver): drives on until its scan callback divides by zero.
BAD_DRIVER = """
    from racecar_sim.msgs import AckermannDriveStamped
    from racecar_sim.nodes import NodeBase


    class Crashy(NodeBase):
        def __init__(self, ctx, crash_ns=2_500_000_000):
            self.ctx, self.crash_ns = ctx, crash_ns
            ctx.bus.subscribe(ctx.topic("/scan"), self.on_scan)

        def on_scan(self, msg):
            if self.ctx.now() >= self.crash_ns:
                self.steer(msg)
            cmd = AckermannDriveStamped()
            cmd.drive.speed = 1.0
            self.ctx.bus.publish(self.ctx.topic("/vesc/ackermann_cmd_mux/input/navigation"), cmd)

        def steer(self, msg):
            return len(msg.ranges) / 0


    class BadStart(NodeBase):
        def __init__(self, ctx):
            raise KeyError("no_such_param")
"""


def _cli(tmp_path: Path, *args: str) -> subprocess.CompletedProcess[str]:
    (tmp_path / "bad.py").write_text(textwrap.dedent(BAD_DRIVER))
    return subprocess.run(
        [sys.executable, "-m", "racecar_sim", "run", *args],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=300,
    )


def test_a_raising_driver_is_one_line_with_its_own_frames_and_the_files_are_kept(tmp_path: Path) -> None:
    done = _cli(tmp_path, "--driver", "bad.py:Crashy", "--no-camera", "--duration", "5", "--out", "out")
    assert done.returncode == NodeError.EXIT_CODE, done.stderr
    errors = [line for line in done.stderr.splitlines() if line.startswith("racecar-sim: error:")]
    assert len(errors) == 1, done.stderr
    line = errors[0]
    for part in ("bad.py:Crashy", "(car racecar)", "ZeroDivisionError: division by zero", "sim time 2.500 s", "/scan"):
        assert part in line, line
    # the traceback: the user's file only, both of its frames, none of the sim's
    trace = done.stderr.split(line, 1)[1]
    assert "racecar_sim" not in trace and "site-packages" not in trace, trace
    assert trace.count('bad.py", line') == 2 and "in on_scan" in trace and "in steer" in trace, trace
    assert trace.rstrip().endswith("ZeroDivisionError: division by zero")
    out = tmp_path / "out"
    summary = json.loads((out / "summary.json").read_text())
    assert summary["ended"] == "error" and summary["duration"] == pytest.approx(2.5)
    assert summary["error"] == {
        "node": "bad.py:Crashy",
        "car": "racecar",
        "time": pytest.approx(2.5),
        "in": "its subscription to /scan",
        "exception": "ZeroDivisionError: division by zero",
    }
    assert summary["cars"]["racecar"]["distance"] > 1.0  # it drove until then
    assert (out / "summary.png").stat().st_size > 10_000
    from rosbags.highlevel import AnyReader

    with AnyReader([out / "run.mcap"]) as reader:  # closed properly: rosbags reads its summary section
        scans = [c for c in reader.connections if c.topic == "/scan"]
        stamps = [t for _, t, _ in reader.messages(scans)]
    assert len(stamps) == 100 and max(stamps) == CRASH_NS  # every scan up to the one the driver choked on


def test_a_driver_raising_while_built_is_one_line(tmp_path: Path) -> None:
    done = _cli(tmp_path, "--driver", "bad.py:BadStart", "--no-camera", "--duration", "1", "--no-record")
    assert done.returncode == NodeError.EXIT_CODE, done.stderr
    first = done.stderr.splitlines()[0]
    assert first.startswith("racecar-sim: error: bad.py:BadStart (car racecar) raised KeyError: 'no_such_param'")
    assert "its constructor" in first and "racecar_sim" not in done.stderr.split(first, 1)[1]


class _Crashy(NodeBase):
    """A node whose timer raises at 1.2 s."""

    def __init__(self, ctx: object) -> None:
        self.ctx = ctx
        ctx.timers.every(10.0, self.tick, "crashy")  # type: ignore[attr-defined]

    def tick(self, now_ns: int) -> None:
        if now_ns >= 1_200_000_000:
            raise RuntimeError("lost the plot")


@pytest.mark.parametrize("factory", [_Crashy, lambda ctx: _Crashy(ctx)], ids=["class", "function"])
def test_run_until_raises_node_error_naming_the_node_and_sim_time_from_the_users_exception(factory) -> None:
    with Simulator(world="empty", camera=False) as sim:
        node = sim.add_node(factory)
        assert isinstance(node, _Crashy)  # the user's own object comes back
        with pytest.raises(NodeError) as caught:
            sim.run_until(3.0)
        assert sim.time == pytest.approx(1.2)  # stopped at that event
    error = caught.value
    assert isinstance(error.__cause__, RuntimeError) and str(error.__cause__) == "lost the plot"
    assert error.node == f"{__name__}:_Crashy" and error.car == "racecar" and error.time == pytest.approx(1.2)
    assert "its timer crashy (10 Hz)" in str(error) and "sim time 1.200 s" in str(error)


def test_a_hook_that_raises_is_named_too() -> None:
    class BadReset(NodeBase):
        def __init__(self, ctx: object) -> None:
            pass

        def reset(self, seed: int) -> None:
            raise ValueError(f"seed {seed}")

    with Simulator(world="empty", camera=False, seed=7) as sim:
        sim.add_node(BadReset)
        sim.run_for(0.1)
        with pytest.raises(NodeError, match="its reset hook") as caught:
            sim.reset()
    assert str(caught.value.__cause__) == "seed 7"


CAR_LAUNCH = """<launch>
  <include file="$(find gazebo_ros)/launch/empty_world.launch"><arg name="world_name" value="walker"/></include>
  <param name="robot_description" command="$(find xacro)/xacro '$(find racecar_description)/urdf/racecar.xacro'"/>
  <node name="spawn" pkg="gazebo_ros" type="spawn_model" args="-urdf -param robot_description -model racecar"/>
</launch>
"""


def test_launch_with_a_raising_driver_keeps_the_run_folder_and_says_so(tmp_path: Path) -> None:
    (tmp_path / "bad.py").write_text(textwrap.dedent(BAD_DRIVER))
    (tmp_path / "car.launch").write_text(CAR_LAUNCH)
    done = subprocess.run(
        [sys.executable, "-m", "racecar_sim", "launch", "car.launch", "--driver", "bad.py:Crashy", "--no-camera"]
        + ["--duration", "4", "--out", "out"],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert done.returncode == NodeError.EXIT_CODE, done.stderr
    (line,) = [line for line in done.stderr.splitlines() if line.startswith("racecar-sim: error:")]
    assert "bad.py:Crashy (car racecar) raised ZeroDivisionError" in line and "sim time 2.500 s" in line
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert summary["ended"] == "error" and summary["launch_file"].endswith("car.launch")
    assert summary["duration"] == pytest.approx(2.5)
