"""Issue 21, hard edges of the CLI: options, fleets, recordings, sweep and bench. Each test runs the real CLI on the
input that broke it (a traceback, a silent acceptance, a hang, a lost recording) and checks the one-line error and
exit code 2, or that the recording is kept and readable by rosbags."""

from __future__ import annotations

import datetime as dt
import resource
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from rosbags.highlevel import AnyReader
from rosbags.typesys import Stores, get_typestore

from racecar_sim import Simulator, Spawn
from racecar_sim.cli import run as run_module
from racecar_sim.cli.main import main
from racecar_sim.cli.spawns import MAX_CARS
from racecar_sim.physics import builder
from racecar_sim.runtime import Car
from racecar_sim.runtime import car as car_module
from racecar_sim.runtime import simulator as simulator_module
from racecar_sim.sweep import load_sweep
from racecar_sim.sweep.spec import MAX_EPISODES

CLI = [sys.executable, "-m", "racecar_sim"]
QUIET = ["--no-camera", "--no-summary", "--no-video"]
SRC = Path(__file__).resolve().parents[1] / "src"


def cli(*args: str, cwd: Path, timeout: float = 120, **kwargs) -> subprocess.CompletedProcess:
    return subprocess.run([*CLI, *args], capture_output=True, text=True, timeout=timeout, cwd=cwd, **kwargs)


def one_error_line(result: subprocess.CompletedProcess | tuple[int, str]) -> str:
    """The only line of stderr of a run that exited 2, without a traceback."""
    code, stderr = (result.returncode, result.stderr) if isinstance(result, subprocess.CompletedProcess) else result
    assert code == 2, stderr
    assert "Traceback" not in stderr
    lines = stderr.strip().splitlines()
    assert len(lines) == 1, stderr
    return lines[0]


def in_process(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, str]:
    """main(argv) in this process: (exit code, stderr), argparse's exits included."""
    try:
        code = main(list(argv))
    except SystemExit as exc:
        code = exc.code
    return code, capsys.readouterr().err


def read_bag(path: Path) -> tuple[int, float]:
    """(messages, last log time in s) of an MCAP, read by rosbags."""
    with AnyReader([path], default_typestore=get_typestore(Stores.EMPTY)) as reader:
        return reader.message_count, reader.end_time / 1e9


# --- 1. --rate ------------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("rate", ["1e-300", "1e-7", "0"])
def test_a_rate_too_small_for_the_scheduler_is_one_line_with_the_range(capsys, rate):
    line = one_error_line(in_process(capsys, "run", "--rate", rate, *QUIET, "--no-record", "--duration", "0.1"))
    assert line.startswith("racecar-sim: error: argument --rate: ")
    assert "from 1e-06 Hz up to the physics rate (400 Hz" in line


def test_a_rate_above_the_physics_rate_names_the_range(tmp_path):
    line = one_error_line(cli("run", "--rate", "1000", *QUIET, "--no-record", "--duration", "0.1", cwd=tmp_path))
    assert line.startswith("racecar-sim: error: --rate: ") and "1e-06 Hz up to the physics rate, 400 Hz" in line


# --- 2. --cars: a real limit, the row checked before the cars are built, and a build that is not N² -------------------
def test_more_cars_than_the_limit_are_refused_at_once(tmp_path):
    line = one_error_line(
        cli("run", "--world", "empty", "--cars", "1000", *QUIET, "--no-record", cwd=tmp_path, timeout=60)
    )
    assert line.startswith("racecar-sim: error: argument --cars: '1000' must be from 1 to ")
    assert str(MAX_CARS) in line


@pytest.mark.parametrize("world, cars, car, fit", [("empty", 200, "car52", 51), ("walker", 7, "car7", 6)])
def test_a_row_off_the_world_is_refused_before_the_cars_are_built(tmp_path, world, cars, car, fit):
    start = time.monotonic()
    line = one_error_line(cli("run", "--world", world, "--cars", str(cars), *QUIET, "--no-record", cwd=tmp_path))
    # building 200 cars took 48 s before anything was checked; the row is checked against the world first
    assert time.monotonic() - start < 20
    assert line.startswith(f"racecar-sim: error: --cars {cars} --car-spacing 1.5: ") and f"{car}'s spawn pose" in line
    assert f"this world takes {fit} cars in a row at 1.5 m" in line


def test_a_fleet_expands_its_xacro_and_ranks_its_friction_once(monkeypatch):
    """Building N cars was N²: the friction ranking after each car went over every geom of the cars before it, and
    each car expanded the same xacro again."""
    calls = {"xacro": 0, "friction": 0}

    def counted(name, function):
        def wrapper(*args, **kwargs):
            calls[name] += 1
            return function(*args, **kwargs)

        return wrapper

    monkeypatch.setattr(car_module, "load_robot", counted("xacro", car_module.load_robot))
    monkeypatch.setattr(builder, "friction_min_rule", counted("friction", builder.friction_min_rule))
    monkeypatch.setattr(
        simulator_module, "friction_min_rule", counted("friction", builder.friction_min_rule), raising=False
    )
    counts = []
    for size in (1, 6):
        calls.update(xacro=0, friction=0)
        cars = [
            Car(f"car{k + 1}", spawn=Spawn(-1.5 * k, 0.0, 0.05, 0.0), camera=False, lidar=False) for k in range(size)
        ]
        with Simulator(world="empty", cars=cars) as sim:
            assert len(sim.cars) == size and sim.cars[-1].robot is sim.cars[0].robot
        counts.append(dict(calls))
    assert counts[0] == counts[1] and counts[1]["xacro"] == 1  # as many for 6 cars as for one


# --- 3. --car-spacing and --spawn: one line naming the option (and the car) ----------------------------------------
@pytest.mark.parametrize(
    "options, starts, has",
    [
        (
            ["--cars", "2", "--car-spacing", "1e6"],
            "--cars 2 --car-spacing 1e+06: walker (racecar_walker.world): ",
            "car2's spawn pose (-1e+06, 0, 0.05, 0) has no ground under it",
        ),
        (
            ["--cars", "2", "--car-spacing", "1e300"],
            "--cars 2 --car-spacing 1e+300: walker (racecar_walker.world): ",
            "car2's spawn pose (-1e+300, 0, 0.05, 0) is beyond 1e+09 m from the origin",
        ),
        (
            ["--cars", "3", "--car-spacing", "0.2"],
            "--car-spacing 0.2: walker (racecar_walker.world): ",
            "car3's spawn pose (-0.4, 0, 0.05, 0) is inside an obstacle",
        ),
        (
            ["--spawn", "1e9,0,0"],
            "--spawn: walker (racecar_walker.world): ",
            "spawn pose (1e+09, 0, 0.05, 0) has no ground under it",
        ),
    ],
)
def test_a_car_spacing_or_spawn_off_the_world_names_the_option(tmp_path, options, starts, has):
    line = one_error_line(cli("run", *options, *QUIET, "--no-record", "--duration", "0.1", cwd=tmp_path))
    assert line.startswith(f"racecar-sim: error: {starts}") and has in line
    assert "Element name" not in line and "MuJoCo" not in line


def test_a_spawn_beyond_the_largest_coordinate_is_refused_by_the_option(capsys):
    line = one_error_line(in_process(capsys, "run", "--spawn", "1e300,0,0", *QUIET, "--no-record"))
    assert line.startswith("racecar-sim: error: argument --spawn: '1e300,0,0': x 1e+300 m is beyond the largest")


# --- 4. --model-path ------------------------------------------------------------------------------------------------
@pytest.mark.parametrize(
    "command", [["run", *QUIET, "--no-record", "--duration", "0.1"], ["worlds", "--show", "empty"]]
)
def test_a_model_path_that_does_not_exist_is_refused(tmp_path, command):
    line = one_error_line(cli(*command, "--model-path", "/does/not/exist", cwd=tmp_path))
    assert line.startswith("racecar-sim: error: --model-path /does/not/exist: no such folder")
    assert not list(tmp_path.iterdir())


# --- 5. worlds --show --spawn: the check `run` does -----------------------------------------------------------------
def test_worlds_show_checks_the_spawn_as_run_does(tmp_path):
    line = one_error_line(cli("worlds", "--show", "walker", "--spawn", "100,100,0", "--out", "w.png", cwd=tmp_path))
    assert line == (
        "racecar-sim: error: --spawn: walker (racecar_walker.world): spawn pose (100, 100, 0.05, 0) has "
        "no ground under it: nothing within 100 m below the left_rear_wheel (the car would fall forever)"
    )
    assert not (tmp_path / "w.png").exists()


# --- 6. bench --quick and --compare --------------------------------------------------------------------------------
def test_bench_quick_without_speed_is_the_quick_form(tmp_path):
    result = cli("bench", "--quick", "--no-camera", cwd=tmp_path)
    assert result.returncode == 0, result.stderr
    assert "2 sim s, best of 1 (--quick" in result.stdout


@pytest.mark.parametrize(
    "compare, why",
    [("/does/not/exist", "no such folder"), (str(SRC), "is this checkout's own src folder"), (".", "not a src folder")],
)
def test_bench_compare_must_be_another_checkouts_src(tmp_path, compare, why):
    line = one_error_line(cli("bench", "--speed", "--quick", "--compare", compare, cwd=tmp_path, timeout=60))
    assert line.startswith(f"racecar-sim: error: --compare {compare}: {why}")


# --- 7. sweep: the grid counted before anything is made --------------------------------------------------------------
@pytest.mark.parametrize(
    "grid, says",
    [
        ("seeds: 1000000000\ndrivers: [constant]\n", f"seeds: 1000000000 seeds are more than the {MAX_EPISODES}"),
        (
            "seeds: 1000\ndrivers:\n  - driver: constant\n    params: {speed: &v [0, 1, 2, 3, 4, 5, 6, 7, 8, 9], "
            "steering: *v, rate: [1, 2, 3, 4, 5, 6, 7, 8, 9, 10]}\n",
            "drivers[0].params: the grid is 1000000 episodes (worlds x seeds 1000 x driver combinations 1000), "
            f"more than the {MAX_EPISODES} a sweep runs",
        ),
    ],
)
def test_a_sweep_grid_too_big_is_refused_before_any_work(tmp_path, grid, says):
    (tmp_path / "big.yaml").write_text("duration: 1\nworlds: [walker]\n" + grid)
    start = time.monotonic()
    line = one_error_line(cli("sweep", "big.yaml", "--local", "--out", "out", cwd=tmp_path, timeout=60))
    assert time.monotonic() - start < 20
    assert line == f"racecar-sim: error: big.yaml: {says}" or (
        line.startswith("racecar-sim: error: big.yaml: ") and says in line
    )
    assert not (tmp_path / "out").exists()


def test_a_sweep_grid_is_counted_and_made_one_episode_at_a_time(tmp_path):
    path = tmp_path / "wide.yaml"
    path.write_text(f"duration: 1\nworlds: [walker]\nseeds: {MAX_EPISODES}\ndrivers: [constant]\n")
    spec = load_sweep(path)
    assert spec.size == MAX_EPISODES
    episodes = spec.iter_episodes()
    first, second = next(episodes), next(episodes)
    assert (first.index, first.seed, second.index, second.seed) == (0, 0, 1, 1)


# --- 8. a recording is never overwritten silently ---------------------------------------------------------------------
def test_two_runs_recording_to_one_path_at_once_never_both_write_it(tmp_path):
    command = [*CLI, "run", *QUIET, "--duration", "3", "--record", "same.mcap"]
    runs = [
        subprocess.Popen(command, cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        for _ in range(2)
    ]
    results = [(run.wait(timeout=120), *run.communicate()) for run in runs]
    codes = sorted(code for code, _, _ in results)
    assert codes == [0, 2], results
    (_, out, _), (_, _, err) = sorted(results, key=lambda r: r[0])
    assert "wrote            same.mcap" in out
    line = one_error_line((2, err))
    assert line.startswith("racecar-sim: error: ") and "same.mcap" in line
    assert ("the file exists" in line and "--overwrite" in line) or "another recording is writing this file" in line
    messages, last = read_bag(tmp_path / "same.mcap")
    assert messages > 0 and last == pytest.approx(3.0, abs=0.05)


def test_an_existing_recording_is_replaced_only_with_overwrite(tmp_path):
    first = cli("run", *QUIET, "--duration", "0.5", "--record", "a.mcap", cwd=tmp_path)
    assert first.returncode == 0, first.stderr
    before = (tmp_path / "a.mcap").read_bytes()
    line = one_error_line(cli("run", *QUIET, "--duration", "1", "--record", "a.mcap", cwd=tmp_path))
    assert line == (
        "racecar-sim: error: --record a.mcap: the file exists and a recording is never replaced unless "
        "asked: give --overwrite to replace it, or another file name"
    )
    assert (tmp_path / "a.mcap").read_bytes() == before
    again = cli("run", *QUIET, "--duration", "1", "--record", "a.mcap", "--overwrite", cwd=tmp_path)
    assert again.returncode == 0, again.stderr
    assert read_bag(tmp_path / "a.mcap")[1] == pytest.approx(1.0, abs=0.05)


def test_two_runs_in_the_same_second_get_a_folder_each(tmp_path, monkeypatch, capsys):
    class Now(dt.datetime):
        @classmethod
        def now(cls, tz=None):
            return cls(2026, 1, 2, 3, 4, 5)

    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(run_module, "datetime", Now)
    earlier = tmp_path / "runs" / "20260102-030405"
    earlier.mkdir(parents=True)
    (earlier / "run.mcap").write_bytes(b"an earlier run's recording")
    assert main(["run", *QUIET, "--duration", "0.3"]) == 0
    assert "wrote            runs/20260102-030405-2/run.mcap" in capsys.readouterr().out
    assert (earlier / "run.mcap").read_bytes() == b"an earlier run's recording"
    assert read_bag(tmp_path / "runs" / "20260102-030405-2" / "run.mcap")[0] > 0


def test_teleop_refuses_an_existing_recording(tmp_path):
    pexpect = pytest.importorskip("pexpect")
    (tmp_path / "old.mcap").write_bytes(b"kept")
    child = pexpect.spawn(
        sys.executable,
        ["-m", "racecar_sim", "teleop", "--no-camera", "--duration", "0.2", "--record", "old.mcap"],
        cwd=str(tmp_path),
        timeout=60,
        encoding="utf-8",
    )
    output = child.read()
    child.close()
    assert child.exitstatus == 2, output
    assert output.strip() == (
        "racecar-sim: error: --record old.mcap: the file exists and a recording is never "
        "replaced unless asked: give --overwrite to replace it, or another file name"
    )
    assert (tmp_path / "old.mcap").read_bytes() == b"kept"


LAUNCH = """<launch>
  <include file="$(find gazebo_ros)/launch/empty_world.launch"><arg name="world_name" value="empty"/></include>
  <param name="robot_description" command="$(find xacro)/xacro '$(find racecar_description)/urdf/racecar.xacro'"/>
  <node name="spawn" pkg="gazebo_ros" type="spawn_model" args="-urdf -param robot_description -model racecar"/>
</launch>
"""


def test_launch_out_refuses_an_existing_recording_and_overwrite_replaces_it(tmp_path):
    (tmp_path / "car.launch").write_text(LAUNCH)
    (tmp_path / "out").mkdir()
    (tmp_path / "out" / "run.mcap").write_bytes(b"kept")
    options = ["launch", "car.launch", "--duration", "0.5", "--no-camera", "--no-lidar", "--out", "out"]
    line = one_error_line(cli(*options, cwd=tmp_path))
    assert line.startswith("racecar-sim: error: --record out/run.mcap: the file exists")
    assert (tmp_path / "out" / "run.mcap").read_bytes() == b"kept"
    again = cli(*options, "--overwrite", cwd=tmp_path)
    assert again.returncode == 0, again.stderr
    assert read_bag(tmp_path / "out" / "run.mcap")[1] == pytest.approx(0.5, abs=0.05)


# --- 9. a full disk: one line, what was kept, a file that recover mends ---------------------------------------------
def _file_size_limit(limit: int):
    def limit_files() -> None:
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)  # a write past the limit fails with EFBIG instead of killing
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))

    return limit_files


def test_a_full_disk_stops_the_run_in_one_line_and_recover_mends_the_file(tmp_path):
    result = cli(
        "run", *QUIET, "--duration", "60", "--record", "run.mcap", cwd=tmp_path, preexec_fn=_file_size_limit(1_000_000)
    )
    line = one_error_line(result)
    assert line.startswith("racecar-sim: error: run.mcap: the recording stopped at sim time ")
    assert "cannot write the file (File too large); it keeps the messages up to sim time " in line
    assert line.endswith("without its index: `racecar-sim recover run.mcap` makes it readable")
    kept = float(line.split("up to sim time ")[1].split(" s")[0])
    assert 1.0 < kept < 60.0
    recovered = cli("recover", "run.mcap", cwd=tmp_path)
    assert recovered.returncode == 0, recovered.stderr
    messages, last = read_bag(tmp_path / "run.recovered.mcap")
    assert messages > 1000 and last == pytest.approx(kept, abs=1e-6)


def test_dev_full_is_one_line_saying_nothing_was_kept(tmp_path):
    line = one_error_line(cli("run", *QUIET, "--duration", "1", "--record", "/dev/full", "--overwrite", cwd=tmp_path))
    assert line == (
        "racecar-sim: error: /dev/full: the recording stopped at its start: cannot write the file (No "
        "space left on device); it keeps no message"
    )
