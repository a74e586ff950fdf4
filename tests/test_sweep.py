"""racecar-sim sweep: a grid of episodes on a local Ray, the results table and each run's files."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import pytest
from mcap.reader import make_reader

from racecar_sim.cli.main import main as cli_main
from racecar_sim.core.errors import ConfigError
from racecar_sim.sweep import load_sweep, run_episode, run_sweep

SWEEP = """\
duration: 2
worlds: [walker]
seeds: [3, 7]
drivers:
  - driver: wall-follow
    params: {distance: [0.6, 1.1], speed: 2.0}
camera: false
"""
SCAN_RATE, ODOM_RATE = 40.0, 20.0  # Hz: the Hokuyo's update_rate, gazebo_odometry.py's rate


@pytest.fixture(scope="module")
def local_ray():
    """One local Ray for the module (its start-up costs seconds): 2 CPUs, no dashboard, workers' logs kept there."""
    ray = pytest.importorskip("ray")
    ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False, configure_logging=False)
    yield
    ray.shutdown()


def _sweep_file(folder: Path, text: str = SWEEP) -> Path:
    path = folder / "sweep.yaml"
    path.write_text(text)
    return path


def _message_counts(path: Path) -> dict[str, int]:
    with open(path, "rb") as f:
        summary = make_reader(f).get_summary()
    return {summary.channels[cid].topic: n for cid, n in summary.statistics.channel_message_counts.items()}


def test_ray_sweep_writes_the_table_and_every_run(tmp_path, local_ray):
    spec = load_sweep(_sweep_file(tmp_path))
    done: list[int] = []
    result = run_sweep(spec, tmp_path / "out", on_row=lambda row: done.append(row["index"]))
    assert sorted(done) == [0, 1, 2, 3]
    assert not result.failed, result.failed

    with open(tmp_path / "out" / "results.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    # the grid: parameters outside, seeds inside, in index order
    assert [(int(r["index"]), float(r["param_distance"]), int(r["seed"])) for r in rows] == [
        (0, 0.6, 3),
        (1, 0.6, 7),
        (2, 1.1, 3),
        (3, 1.1, 7),
    ]
    for row in rows:
        assert row["world"] == "walker" and row["driver"] == "wall-follow" and row["error"] == ""
        assert float(row["param_speed"]) == 2.0
        assert float(row["sim_time"]) == pytest.approx(2.0)
        assert float(row["real_time_factor"]) == pytest.approx(2.0 / float(row["wall_time"]))
        # wall-follow drives off at once, no faster than its top speed, along walker's open start
        distance = float(row["distance"])
        assert 0.5 < distance < 2.0 * 2.0
        assert float(row["mean_speed"]) == pytest.approx(distance / 1.95, rel=0.1)  # odometry spans 2 s less a tick
        assert int(row["collisions"]) == 0 and 0.1 < float(row["min_clearance"]) < 10.0

        folder = tmp_path / "out" / row["folder"]
        assert folder.name == f"{int(row['index']):03d}-walker-wall-follow-seed{row['seed']}"
        counts = _message_counts(folder / "run.mcap")
        assert counts["/scan"] == pytest.approx(2.0 * SCAN_RATE, abs=1)
        assert counts["/vesc/odom"] == pytest.approx(2.0 * ODOM_RATE, abs=1)
        assert json.loads((folder / "summary.json").read_text())["distance"] == pytest.approx(distance)
    # a wider distance to the wall is a different run; the same settings and seed on Ray and here are the same run
    assert rows[0]["distance"] != rows[2]["distance"]
    episode = spec.episodes()[1]
    here = run_episode(episode, tmp_path / "here")
    assert here["distance"] == pytest.approx(float(rows[1]["distance"]), abs=1e-9)
    assert here["final_x"] == pytest.approx(float(rows[1]["final_x"]), abs=1e-9)

    pyarrow = pytest.importorskip("pyarrow.parquet")
    table = pyarrow.read_table(tmp_path / "out" / "results.parquet").to_pydict()
    assert table["seed"] == [3, 7, 3, 7] and table["param_distance"] == [0.6, 0.6, 1.1, 1.1]
    assert table["distance"] == pytest.approx([float(r["distance"]) for r in rows])


def test_local_sweep_counts_a_crash(tmp_path, capsys):
    """--local, no Ray: a car driven straight at walker's wall crashes once; one steered round the open start
    does not."""
    path = _sweep_file(
        tmp_path,
        "duration: 6\nworlds: [walker]\nseeds: 1\ndrivers:\n"
        "  - {driver: constant, params: {speed: 2.0, steering: [0.0, 0.3]}}\n",
    )
    assert cli_main(["sweep", str(path), "--out", str(tmp_path / "out"), "--local"]) == 0
    assert "2 of 2 episodes ran" in capsys.readouterr().out
    with open(tmp_path / "out" / "results.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    straight, turning = rows
    assert int(straight["collisions"]) == 1 and 3.0 < float(straight["first_collision_time"]) < 6.0
    assert int(turning["collisions"]) == 1
    assert (tmp_path / "out" / "sweep.yaml").read_text() == path.read_text()


@pytest.mark.parametrize(
    "text, expected",
    [
        ("worlds: [walker]\nseeds: [0]\n", "missing field 'drivers'"),
        (
            "worlds: [walker]\nseeds: [0]\ndrivers: [{driver: wall-follow, params: {distnce: 1}}]\n",
            "drivers[0].params: wall-follow has no parameter 'distnce'",
        ),
        (
            "worlds: [walker]\nseeds: [0]\ndrivers: [{driver: wall-follow, params: {distance: [0.5, -1]}}]\n",
            "drivers[0].params: wall-follow: WallFollowConfig: distance must be positive",
        ),
        ("worlds: [nowhere]\nseeds: [0]\ndrivers: [constant]\n", "worlds: 'nowhere' is neither a built-in world"),
        ("worlds: [walker]\nseeds: [0, -1]\ndrivers: [constant]\n", "seeds: a seed is a whole number >= 0"),
        ("worlds: [walker]\nseeds: 2\nduration: 0\ndrivers: [teleport]\n", "duration: must be positive"),
        ("worlds: [walker]\nseeds: 2\ndrivers: [pure-pursuit]\n", "drivers[0].params.path: pure-pursuit needs a path"),
        ("worlds: [walker\n", "not valid YAML"),
    ],
)
def test_sweep_file_errors_name_the_file_and_field(tmp_path, capsys, text, expected):
    path = _sweep_file(tmp_path, text)
    with pytest.raises(ConfigError, match=r"sweep\.yaml: "):
        load_sweep(path)
    assert cli_main(["sweep", str(path), "--out", str(tmp_path / "out"), "--local"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and str(path) in err[0] and expected in err[0], err
    assert not (tmp_path / "out").exists()


def test_without_ray_the_cli_says_how_to_install_it(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr("racecar_sim.cli.sweep.ray_available", lambda: False)
    assert cli_main(["sweep", str(_sweep_file(tmp_path)), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and 'pip install -e ".[ray]"' in err[0] and "--local" in err[0]
