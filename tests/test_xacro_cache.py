"""The kept xacro expansions (description/xacro_cache.py): the same text as xacro's own expansion, taken from disk only
while every file read, `$(find)` answer, variable read and argument is the same as when it was kept."""

from __future__ import annotations

import os
import textwrap
from pathlib import Path

import pytest
import xacro

from racecar_sim.description import DEFAULT_XACRO, expand_xacro, ros_packages, xacro_cache


@pytest.fixture
def cache(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """A cache of the test's own (XDG_CACHE_HOME), and a count of the expansions xacro really does."""
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    monkeypatch.delenv(xacro_cache.OFF_VARIABLE, raising=False)
    return tmp_path / "cache" / "racecar-sim" / "xacro"


@pytest.fixture
def expansions(monkeypatch: pytest.MonkeyPatch) -> list[str]:
    done: list[str] = []
    original = xacro.process_file

    def counted(name: str, **kwargs: object) -> object:
        done.append(name)
        return original(name, **kwargs)

    monkeypatch.setattr(xacro, "process_file", counted)
    return done


def _write(folder: Path, width: str = "0.3") -> Path:
    (folder / "parts.xacro").write_text(
        textwrap.dedent(f"""\
        <robot xmlns:xacro="http://www.ros.org/wiki/xacro">
          <xacro:property name="width" value="{width}"/>
        </robot>
        """)
    )
    top = folder / "car.xacro"
    top.write_text(
        textwrap.dedent("""\
        <robot name="car" xmlns:xacro="http://www.ros.org/wiki/xacro">
          <xacro:arg name="length" default="0.5"/>
          <xacro:include filename="parts.xacro"/>
          <link name="base">
            <visual><geometry><box size="$(arg length) ${width} 0.1"/></geometry></visual>
          </link>
          <xacro:unless value="$(optenv NO_EXTRA_LINK false)"><link name="extra"/></xacro:unless>
        </robot>
        """)
    )
    return top


def test_the_shipped_car_from_the_cache_is_xacros_own_expansion(cache, expansions, monkeypatch):
    monkeypatch.setenv(xacro_cache.OFF_VARIABLE, "0")
    fresh = expand_xacro(DEFAULT_XACRO)
    monkeypatch.delenv(xacro_cache.OFF_VARIABLE)
    assert not cache.exists()  # turned off: nothing kept
    assert expand_xacro(DEFAULT_XACRO) == fresh and len(expansions) == 2  # kept now
    assert expand_xacro(DEFAULT_XACRO) == fresh and len(expansions) == 2  # from the cache, xacro not called
    assert len(list(cache.glob("*.json"))) == 1


def test_an_edited_include_an_argument_or_a_variable_expands_again(cache, expansions, tmp_path, monkeypatch):
    monkeypatch.delenv("NO_EXTRA_LINK", raising=False)
    top = _write(tmp_path)
    first = expand_xacro(top)
    assert 'size="0.5 0.3 0.1"' in first and '<link name="extra"/>' in first
    assert expand_xacro(top) == first and len(expansions) == 1

    _write(tmp_path, width="0.4")  # the include, same length, edited
    assert 'size="0.5 0.4 0.1"' in expand_xacro(top) and len(expansions) == 2

    assert 'size="0.7 0.4 0.1"' in expand_xacro(top, {"length": "0.7"}) and len(expansions) == 3

    monkeypatch.setenv("NO_EXTRA_LINK", "true")  # $(optenv NO_EXTRA_LINK): the variable is part of the entry
    assert '<link name="extra"/>' not in expand_xacro(top) and len(expansions) == 4
    assert '<link name="extra"/>' not in expand_xacro(top) and len(expansions) == 4


def test_a_package_found_elsewhere_expands_again(cache, expansions, tmp_path, monkeypatch):
    """`$(find pkg)`: the same ROS_PACKAGE_PATH, but the package answered from another folder now."""
    roots = [tmp_path / "a", tmp_path / "b"]
    for root, width in zip(roots, ("0.3", "0.6")):
        package = root / "parts_pkg"
        package.mkdir(parents=True)
        (package / "package.xml").write_text("<package><name>parts_pkg</name></package>")
        _write(package, width)
    top = tmp_path / "top.xacro"
    top.write_text(
        '<robot name="t" xmlns:xacro="http://www.ros.org/wiki/xacro">'
        '<xacro:include filename="$(find parts_pkg)/parts.xacro"/><link name="l${width}"/></robot>'
    )
    monkeypatch.setenv("ROS_PACKAGE_PATH", os.pathsep.join(map(str, roots)))
    assert 'name="l0.3"' in expand_xacro(top)
    assert 'name="l0.3"' in expand_xacro(top) and len(expansions) == 1
    (roots[0] / "parts_pkg" / "package.xml").unlink()  # a's package gone: b's answers the same $(find)
    ros_packages._crawls.clear()  # as in the next process (one process keeps its crawl of a path)
    assert 'name="l0.6"' in expand_xacro(top) and len(expansions) == 2


def test_a_failed_expansion_is_not_kept(cache, tmp_path):
    top = tmp_path / "bad.xacro"
    top.write_text('<robot xmlns:xacro="http://www.ros.org/wiki/xacro"><link name="${undefined}"/></robot>')
    with pytest.raises(Exception, match="undefined"):
        expand_xacro(top)
    assert not cache.exists() or not list(cache.glob("*.json"))


def test_the_file_named_relative_or_absolute_keeps_xacros_own_banner(cache, tmp_path, monkeypatch):
    top = _write(tmp_path)
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv(xacro_cache.OFF_VARIABLE, "0")
    fresh = {name: expand_xacro(name) for name in ("car.xacro", str(top))}
    monkeypatch.delenv(xacro_cache.OFF_VARIABLE)
    assert fresh["car.xacro"] != fresh[str(top)]  # the banner names the file as given
    for _ in range(2):  # kept, then from the cache
        assert {name: expand_xacro(name) for name in fresh} == fresh


def test_an_expansion_that_warns_is_not_kept(cache, tmp_path, monkeypatch, capsys):
    """What xacro says on stderr (as its warning() does) is said again by the next run: such an expansion is not
    kept."""
    top = _write(tmp_path)
    original = xacro.process_file

    def warns(*args: object, **kwargs: object) -> object:
        xacro.color.warning("deprecated: something in this file")  # xacro's own warning, to sys.stderr
        return original(*args, **kwargs)

    monkeypatch.setattr(xacro, "process_file", warns)
    assert expand_xacro(top) == expand_xacro(top)
    assert capsys.readouterr().err.count("deprecated: something in this file") == 2
    assert not cache.exists() or not list(cache.glob("*.json"))
