"""roslaunch substitution args, checked against roslaunch's documented semantics (substitution_args.py)."""

from __future__ import annotations

from pathlib import Path

import pytest

from racecar_sim.launch.errors import SubstitutionError
from racecar_sim.launch.substitution import Context, convert_value, resolve


def ctx(**args: str) -> Context:
    return Context(args, Path("/somewhere/launch/x.launch"))


def test_arg_and_several_substitutions_in_one_value():
    assert resolve("$(arg a)/$(arg b).world", ctx(a="worlds", b="tunnel")) == "worlds/tunnel.world"


def test_eval_sees_args_by_bare_name_and_through_arg_with_auto_types():
    c = ctx(x="1.5", n="3", flag="true", name="car")
    assert resolve("$(eval x * 2)", c) == "3.0"
    assert resolve("$(eval arg('n') + 1)", c) == "4"
    assert resolve("$(eval 'on' if flag else 'off')", c) == "on"
    assert resolve("$(eval name + '_' + str(n))", c) == "car_3"
    assert resolve("$(eval true and not false)", c) == "True"
    assert resolve("$(eval radians(180) == pi)", c) == "True"  # math's functions are in scope


def test_eval_refuses_dunders_and_names_an_unknown_name():
    with pytest.raises(SubstitutionError, match="double underscores"):
        resolve("$(eval ().__class__)", ctx())
    with pytest.raises(SubstitutionError, match="nope"):
        resolve("$(eval nope + 1)", ctx())


def test_eval_must_be_the_whole_value():
    with pytest.raises(SubstitutionError, match="whole attribute"):
        resolve("x$(eval 1 + 1)", ctx())


def test_env_and_optenv(monkeypatch):
    monkeypatch.setenv("RACECAR_TEST_VAR", "here")
    monkeypatch.delenv("RACECAR_TEST_UNSET", raising=False)
    assert resolve("$(env RACECAR_TEST_VAR)", ctx()) == "here"
    assert resolve("$(optenv RACECAR_TEST_VAR fallback)", ctx()) == "here"
    assert resolve("$(optenv RACECAR_TEST_UNSET fallback with spaces)", ctx()) == "fallback with spaces"
    assert resolve("[$(optenv RACECAR_TEST_UNSET)]", ctx()) == "[]"
    assert resolve("$(eval optenv('RACECAR_TEST_UNSET', 'd') + env('RACECAR_TEST_VAR'))", ctx()) == "dhere"
    with pytest.raises(SubstitutionError, match="RACECAR_TEST_UNSET is not set"):
        resolve("$(env RACECAR_TEST_UNSET)", ctx())


def test_find_goes_through_ros_package_path_first(tmp_path, monkeypatch):
    own = tmp_path / "src" / "racecar_control"  # a user's own copy of a package racecar-sim also ships
    own.mkdir(parents=True)
    (own / "package.xml").write_text(
        "<package format='2'><name>racecar_control</name><version>1.0.0</version>"
        "<description>d</description><maintainer email='a@b.c'>m</maintainer>"
        "<license>BSD</license></package>"
    )
    monkeypatch.setenv("ROS_PACKAGE_PATH", str(tmp_path / "src"))
    assert resolve("$(find racecar_control)/config/x.yaml", ctx()) == f"{own}/config/x.yaml"
    assert resolve("$(eval find('racecar_control'))", ctx()) == str(own)
    monkeypatch.setenv("ROS_PACKAGE_PATH", "")
    shipped = Path(resolve("$(find racecar_control)", ctx()))
    assert shipped != own and (shipped / "config" / "racecar_control.yaml").is_file()


def test_dirname_anon_and_unknown_substitutions():
    c = ctx()
    assert resolve("$(dirname)/car.launch", c) == "/somewhere/launch/car.launch"
    first = resolve("$(anon node)", c)
    assert first.startswith("node_") and resolve("$(anon node)", c) == first and resolve("$(anon other)", c) != first
    with pytest.raises(SubstitutionError, match=r"unknown substitution \$\(fnd pkg\)"):
        resolve("$(fnd pkg)/x", c)
    with pytest.raises(SubstitutionError, match="no arg 'missing'"):
        resolve("$(arg missing)", c)


@pytest.mark.parametrize(
    ("text", "kind", "value"),
    [
        ("1", "auto", 1),
        ("1.5", "auto", 1.5),
        ("True", "auto", True),
        ("false", "auto", False),
        ("abc", "auto", "abc"),
        ("1", "str", "1"),
        ("2", "double", 2.0),
        ("0", "bool", False),
        ("[1, 2]", "yaml", [1, 2]),
    ],
)
def test_param_types_convert_as_roslaunch(text, kind, value):
    result = convert_value(text, kind)
    assert result == value and type(result) is type(value)
