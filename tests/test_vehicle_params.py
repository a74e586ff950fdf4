"""Vehicle parameter sets: F1TENTH's published numbers, a user's YAML file in F1TENTH's names, one-line errors."""

from __future__ import annotations

from pathlib import Path

import pytest

from racecar_sim.core.errors import ConfigError
from racecar_sim.description.vehicle_params import load_vehicle, vehicle_names


def test_the_shipped_sets():
    assert {"seed", "f1tenth"} <= set(vehicle_names())
    assert load_vehicle("seed").tyre_model == "none"  # the seed's Coulomb contact
    f1 = load_vehicle("f1tenth")
    # f1tenth_gym's f110_env.py default parameters
    published = {"mu": 1.0489, "C_Sf": 4.718, "C_Sr": 5.4562, "s_min": -0.4189, "s_max": 0.4189, "sv_max": 3.2}
    published |= {"sv_min": -3.2, "a_max": 9.51, "v_min": -5.0, "v_max": 20.0, "v_switch": 7.319}
    assert {k: getattr(f1, k) for k in published} == published
    assert f1.tyre_model == "linear"
    # the single-track understeer gradient of load-normalised stiffness, (1/mu)(1/C_Sf - 1/C_Sr), in rad/g
    assert f1.understeer_gradient == pytest.approx(0.027, abs=0.001)


def test_a_users_file_with_pacejka_tyres(tmp_path: Path):
    path = tmp_path / "nuc2.yaml"
    # ForzaETH's NUC2 fit: front B C D E, rear B C D E
    path.write_text("mu: 0.9\nC_Sf: 4.0\nC_Sr: 5.0\nC_Pf: [4.80, 2.16, 0.650, 0.373]\nC_Pr: [20.0, 1.5, 0.618, 0.0]\n")
    car = load_vehicle(path)
    assert car.name == "nuc2" and car.tyre_model == "pacejka"
    assert car.pacejka_front == (4.80, 2.16, 0.650, 0.373) and car.pacejka_rear == (20.0, 1.5, 0.618, 0.0)
    assert load_vehicle(str(path)) == car


@pytest.mark.parametrize(
    ("text", "field"),
    [
        ("mu: fast\n", "mu"),
        ("C_Sf: 4.0\nC_Sr: -1\n", "C_Sr"),
        ("C_Pf: [1, 2, 3]\nC_Pr: [1, 2, 3, 4]\n", "C_Pf"),
        ("C_Pf: [1, 2, 3, 0]\n", "C_Pf"),
        ("tyre_grip: 3\n", "tyre_grip"),
        ("s_min: 0.5\ns_max: 0.4\n", "s_min"),
        ("[1, 2]\n", "mapping"),
    ],
)
def test_a_bad_file_is_one_line_naming_file_and_field(tmp_path: Path, text: str, field: str):
    path = tmp_path / "car.yaml"
    path.write_text(text)
    with pytest.raises(ConfigError) as error:
        load_vehicle(path)
    message = str(error.value)
    assert "\n" not in message and str(path) in message and field in message


def test_an_unknown_name_lists_the_sets():
    with pytest.raises(ConfigError, match="f1tenth"):
        load_vehicle("gokart")


def test_the_cli_takes_a_vehicle_and_names_a_bad_file_in_one_line(tmp_path: Path):
    import subprocess
    import sys

    bad = tmp_path / "car.yaml"
    bad.write_text("mu: lots\n")
    result = subprocess.run(
        [sys.executable, "-m", "racecar_sim", "run", "--world", "empty", "--duration", "0.1", "--vehicle", str(bad)],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert result.returncode == 2 and "Traceback" not in result.stderr
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and str(bad) in lines[0] and "mu" in lines[0]


def test_a_file_read_again_after_it_changed(tmp_path: Path):
    """A fleet's cars read one set, parsed once: the same file again gives the same set, and the file's new text
    (a user editing it between two simulators of one process) gives the new numbers."""
    path = tmp_path / "mine.yaml"
    path.write_text("mu: 0.8\nC_Sf: 4.0\nC_Sr: 5.0\n")
    first = load_vehicle(path)
    assert load_vehicle(str(path)) == first
    assert (first.mu, first.C_Sf, first.tyre_model) == (0.8, 4.0, "linear")
    path.write_text("mu: 0.6\n")
    again = load_vehicle(path)
    assert (again.mu, again.C_Sf, again.tyre_model) == (0.6, None, "none")
    path.write_text("mu: -1\n")
    with pytest.raises(ConfigError, match="mu must be positive"):
        load_vehicle(path)
