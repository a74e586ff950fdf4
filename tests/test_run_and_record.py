"""End to end: `racecar-sim run` records MCAP that rosbags reads; same seed, same bytes; Ctrl-C keeps the file."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from mcap.reader import make_reader
from rosbags.highlevel import AnyReader
from rosbags.typesys import Stores, get_typestore

CLI = [sys.executable, "-m", "racecar_sim"]


def default_sigint() -> None:
    """A shell's background job starts with SIGINT ignored; the child needs the default to see Ctrl-C."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)


CONSTANT = ["run", "--world", "empty", "--driver", "constant"]  # the pre-main-job `run`: a constant command


def run_cli(*args: str, **kwargs) -> subprocess.CompletedProcess:
    return subprocess.run([*CLI, *args], capture_output=True, text=True, timeout=120, **kwargs)


def payloads(path: Path) -> list[tuple[str, int, bytes]]:
    with open(path, "rb") as f:
        return [
            (channel.topic, message.log_time, message.data)
            for _, channel, message in make_reader(f).iter_messages(log_time_order=True)
        ]


def test_run_prints_summary_and_records_every_topic(tmp_path):
    out = tmp_path / "circle.mcap"
    result = run_cli(
        *CONSTANT,
        "--duration",
        "10",
        "--speed",
        "1.0",
        "--steering",
        "0.2",
        "--record",
        str(out),
        "--out",
        str(tmp_path),
    )
    assert result.returncode == 0, result.stderr
    assert "real-time factor" in result.stdout and "distance" in result.stdout
    distance = float(next(line for line in result.stdout.splitlines() if line.startswith("distance")).split()[1])
    assert distance == pytest.approx(10.0 * 0.99, rel=0.03)  # 1 m/s, less the first metres of acceleration
    with AnyReader([out], default_typestore=get_typestore(Stores.EMPTY)) as reader:
        topics = {c.topic: c.msgtype for c in reader.connections}
        counts = {c.topic: c.msgcount for c in reader.connections}
        assert topics["/vesc/odom"] == "nav_msgs/msg/Odometry"
        assert topics["/racecar/joint_states"] == "sensor_msgs/msg/JointState"
        assert topics["/vesc/low_level/ackermann_cmd_mux/output"] == "ackermann_msgs/msg/AckermannDriveStamped"
        assert topics["/tf_static"] == "tf2_msgs/msg/TFMessage" and topics["/clock"] == "rosgraph_msgs/msg/Clock"
        assert topics["/racecar/left_steering_hinge_position_controller/command"] == "std_msgs/msg/Float64"
        assert counts["/vesc/odom"] == 200 and counts["/racecar/joint_states"] == 500 and counts["/tf_static"] == 1
        odom = [c for c in reader.connections if c.topic == "/vesc/odom"]
        last = None
        for connection, timestamp, raw in reader.messages(connections=odom):
            last = reader.deserialize(raw, connection.msgtype), timestamp
        msg, log_time = last
        assert log_time == 10_000_000_000  # log time is sim time
        assert msg.header.frame_id == "map" and msg.child_frame_id == "odom"


def test_same_seed_gives_identical_recordings(tmp_path):
    files = []
    for name in ("a.mcap", "b.mcap"):
        files.append(tmp_path / name)
        assert (
            run_cli(
                *CONSTANT,
                "--duration",
                "3",
                "--steering",
                "0.3",
                "--seed",
                "7",
                "--record",
                str(files[-1]),
                "--out",
                str(tmp_path / name[0]),
            ).returncode
            == 0
        )
    first, second = payloads(files[0]), payloads(files[1])
    assert len(first) > 1000 and first == second


@pytest.mark.skipif(os.name != "posix", reason="signals")
def test_interrupted_run_leaves_a_readable_recording(tmp_path):
    out = tmp_path / "interrupted.mcap"
    proc = subprocess.Popen(
        [*CLI, *CONSTANT, "--duration", "3000", "--realtime", "--record", str(out), "--out", str(tmp_path)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        preexec_fn=default_sigint,
    )
    deadline = time.time() + 60
    while time.time() < deadline and (not out.exists() or out.stat().st_size < 2000):
        time.sleep(0.2)
    time.sleep(1.5)
    proc.send_signal(signal.SIGINT)
    _, stderr = proc.communicate(timeout=60)
    assert proc.returncode == 130, stderr
    with AnyReader([out], default_typestore=get_typestore(Stores.EMPTY)) as reader:
        assert sum(c.msgcount for c in reader.connections if c.topic == "/vesc/odom") >= 20


# A driver that signals its own process in the middle of its scan callback and then goes on with it: the callback's
# remaining lines (the marker file) must still run, wherever the signal lands.
SELF_SIGNALLING_DRIVER = """
import os
import signal
from pathlib import Path

from racecar_sim.msgs import AckermannDriveStamped
from racecar_sim.nodes import NodeBase


class Signaller(NodeBase):
    def __init__(self, ctx, signum=15, at_ns=1_000_000_000):
        self.ctx, self.signum, self.at_ns, self.sent = ctx, signum, at_ns, False
        ctx.bus.subscribe(ctx.topic("/scan"), self.on_scan)

    def on_scan(self, msg):
        if self.ctx.now() >= self.at_ns and not self.sent:
            self.sent = True
            os.kill(os.getpid(), self.signum)
            for _ in range(1000):  # bytecode boundaries enough for a raising handler to have run
                pass
            Path("after_signal.txt").write_text(str(self.ctx.now()))
        cmd = AckermannDriveStamped()
        cmd.drive.speed = 1.0
        self.ctx.bus.publish(self.ctx.topic("/vesc/ackermann_cmd_mux/input/navigation"), cmd)
"""


@pytest.mark.skipif(os.name != "posix", reason="signals")
@pytest.mark.parametrize("signum", [signal.SIGTERM, signal.SIGINT])
def test_a_signal_inside_the_loop_is_noted_and_ends_the_run_after_the_slice(tmp_path, signum):
    (tmp_path / "signaller.py").write_text(SELF_SIGNALLING_DRIVER)
    (tmp_path / "settings.yaml").write_text(f"signum: {int(signum)}\n")
    done = subprocess.run(
        [*CLI, "run", "--world", "empty", "--driver", "signaller.py:Signaller", "--driver-config", "settings.yaml",
         "--no-camera", "--no-video", "--duration", "5", "--out", "out"],
        cwd=tmp_path, capture_output=True, text=True, timeout=120, preexec_fn=default_sigint,
    )  # fmt: skip
    assert done.returncode == 130, done.stderr
    assert "Traceback" not in done.stderr and "Exception ignored" not in done.stderr, done.stderr
    # the callback ran to its end: the signal was noted, not raised inside it
    assert int((tmp_path / "after_signal.txt").read_text()) == 1_000_000_000
    # the run stopped at the end of the slice the signal came in (run's CHUNK, 0.1 s), with its files complete
    stopped = float(done.stderr.split("interrupted at sim time ", 1)[1].split(" s", 1)[0])
    assert 1.0 <= stopped <= 1.1 + 1e-9, done.stderr
    with AnyReader([tmp_path / "out" / "run.mcap"], default_typestore=get_typestore(Stores.EMPTY)) as reader:
        stamps = [t for c, t, _ in reader.messages() if c.topic == "/vesc/odom"]
    assert stamps and 1.0e9 <= max(stamps) <= 1.1e9 + 1


def test_bad_arguments_give_one_line_and_exit_2():
    for args in (
        ["run", "--speed", "nan"],
        ["run", "--profile", "fast"],
        ["run", "--duration", "-1"],
        ["run", "--world", "no_such_world"],
        ["run", "--spawn", "1,2"],
    ):
        result = run_cli(*args)
        assert result.returncode == 2, args
        lines = result.stderr.strip().splitlines()
        assert len(lines) == 1 and "error" in lines[0], (args, result.stderr)
