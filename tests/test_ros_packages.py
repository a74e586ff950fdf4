"""ROS package lookup as rospack does it: $(find), package:// and model:// through ROS_PACKAGE_PATH."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from conftest import laser_pose
from racecar_sim import Simulator
from racecar_sim.core.errors import ConfigError
from racecar_sim.description import DEFAULT_XACRO, load_robot, package_path
from racecar_sim.description.ros_packages import (
    SHIPPED_ROOTS,
    PackageNotFound,
    add_package_path,
    find_package,
    gazebo_model_dirs,
    resolve_uri,
)
from ros_package_helpers import (
    SHIPPED_URDF,
    write_description_package,
    write_package_xml,
)

WALL_X, WALL_THICKNESS = 2.0, 0.2  # the box_wall model's centre (as included) and thickness, m


@pytest.fixture(autouse=True)
def no_user_paths(monkeypatch):
    for variable in ("ROS_PACKAGE_PATH", "GAZEBO_MODEL_PATH", "GZ_SIM_RESOURCE_PATH", "SDF_PATH"):
        monkeypatch.delenv(variable, raising=False)


def test_packages_are_found_on_the_path_first_then_among_the_shipped(tmp_path, monkeypatch):
    assert find_package("racecar_description") == SHIPPED_ROOTS[0] / "racecar_description"
    assert package_path("racecar_control") == SHIPPED_ROOTS[0] / "racecar_control"
    first, second = tmp_path / "ws1", tmp_path / "ws2"
    mine = write_package_xml(first / "src" / "deep" / "folder_name_differs", "racecar_description")
    write_package_xml(second / "racecar_description", "racecar_description")
    write_package_xml(first / "ignored" / "other", "other_pkg")
    (first / "ignored" / "CATKIN_IGNORE").touch()
    monkeypatch.setenv("ROS_PACKAGE_PATH", f"{first}:{second}")
    assert find_package("racecar_description") == mine  # the package.xml's <name>, the first path wins
    assert find_package("racecar_control") == SHIPPED_ROOTS[0] / "racecar_control"
    with pytest.raises(PackageNotFound) as err:
        find_package("other_pkg", needed_by="some/file.xacro")
    message = str(err.value)
    assert "\n" not in message and "some/file.xacro" in message and "'other_pkg'" in message
    assert "--package-path" in message and "ROS_PACKAGE_PATH" in message


def test_a_package_made_after_a_crawl_is_found(tmp_path, monkeypatch):
    monkeypatch.setenv("ROS_PACKAGE_PATH", str(tmp_path))
    with pytest.raises(PackageNotFound):
        find_package("late_pkg")
    write_package_xml(tmp_path / "late_pkg", "late_pkg")
    assert find_package("late_pkg") == tmp_path / "late_pkg"


def test_uris_resolve_through_packages_and_folders(tmp_path, monkeypatch):
    write_package_xml(tmp_path / "its_pkg", "its_pkg")
    monkeypatch.setenv("ROS_PACKAGE_PATH", str(tmp_path))
    assert resolve_uri("package://its_pkg/meshes/a.stl") == tmp_path / "its_pkg" / "meshes" / "a.stl"
    assert resolve_uri("file:///abs/b.dae") == Path("/abs/b.dae")
    assert resolve_uri("meshes/c.stl", tmp_path) == tmp_path / "meshes" / "c.stl"
    assert resolve_uri("model://its_pkg/models/m") == tmp_path / "its_pkg" / "models" / "m"
    with pytest.raises(ConfigError, match="only package://"):
        resolve_uri("http://example.com/a.stl")


def test_add_package_path_prepends_and_refuses_missing_folders(tmp_path, monkeypatch):
    monkeypatch.setenv("ROS_PACKAGE_PATH", "/opt/ros/old")
    add_package_path([tmp_path])
    assert os.environ["ROS_PACKAGE_PATH"] == f"{tmp_path.resolve()}:/opt/ros/old"
    with pytest.raises(ConfigError, match="--package-path .*nowhere"):
        add_package_path([tmp_path / "nowhere"])


def test_the_users_racecar_description_shadows_the_shipped_one(tmp_path, monkeypatch):
    """A user's racecar.xacro including its own macros.xacro, with a macro only it defines: once "unknown macro
    name", since $(find racecar_description) always pointed at the shipped copy."""
    xacro = write_description_package(
        tmp_path, "racecar_description", edit={'<xacro:bumper_geometry x="0.40"/>': "<xacro:user_only_bumper/>"}
    )
    macros = xacro.parent / "macros.xacro"
    macros.write_text(
        macros.read_text().replace(
            "</robot>",
            '<xacro:macro name="user_only_bumper"><geometry><sphere radius="0.0321"/></geometry></xacro:macro></robot>',
        )
    )
    monkeypatch.setenv("ROS_PACKAGE_PATH", str(tmp_path))
    robot = load_robot(xacro)
    spheres = [v for v in robot.links["chassis_inertia"].visuals if v.geometry.kind == "sphere"]
    assert [s.geometry.size[0] for s in spheres] == [0.0321]
    # the shipped car keeps its own includes, whatever the user's path holds
    assert load_robot(DEFAULT_XACRO).links.keys() == robot.links.keys()
    assert SHIPPED_URDF == DEFAULT_XACRO.parent


def test_gazebo_model_dirs_honour_gazebo_ros_exports(tmp_path, monkeypatch):
    package = write_package_xml(
        tmp_path / "ws" / "my_worlds", "my_worlds", export='<gazebo_ros gazebo_model_path="${prefix}/models"/>'
    )
    write_package_xml(
        tmp_path / "ws" / "sub" / "racecar_gazebo",
        "racecar_gazebo",
        export='<gazebo_ros gazebo_model_path="${prefix}/.."/>',
    )  # as the original's package.xml
    write_package_xml(tmp_path / "later" / "other", "other")
    monkeypatch.setenv("ROS_PACKAGE_PATH", f"{tmp_path / 'ws'}:{tmp_path / 'later'}")
    monkeypatch.setenv("GAZEBO_MODEL_PATH", str(tmp_path / "gz"))
    dirs = gazebo_model_dirs()
    assert dirs.index(tmp_path / "gz") < dirs.index(package / "models") < dirs.index(tmp_path / "ws" / "sub")
    assert dirs.index(tmp_path / "ws") < dirs.index(tmp_path / "later")  # the path's own order
    assert len(dirs) == len(set(dirs)) == 5


def test_a_broken_package_xml_on_the_path_is_one_line(tmp_path, monkeypatch):
    (tmp_path / "broken").mkdir()
    (tmp_path / "broken" / "package.xml").write_text("<package><name>unclosed")
    monkeypatch.setenv("ROS_PACKAGE_PATH", str(tmp_path))
    with pytest.raises(ConfigError) as err:
        find_package("anything")
    assert str(tmp_path / "broken" / "package.xml") in str(err.value) and "\n" not in str(err.value)
    with Simulator(world="walker", camera=False, lidar=False) as sim:  # built-in worlds and car need no crawl
        assert sim.car.robot.name == "racecar"


def _box_wall_model(models):
    wall = models / "box_wall"
    wall.mkdir(parents=True)
    (wall / "model.config").write_text(
        "<?xml version='1.0'?><model><name>box_wall</name><sdf version='1.6'>model.sdf</sdf></model>"
    )
    geometry = f"<geometry><box><size>{WALL_THICKNESS} 4 1</size></box></geometry>"
    (wall / "model.sdf").write_text(
        f"<?xml version='1.0'?><sdf version='1.6'><model name='box_wall'><static>true</static>"
        f"<link name='l'><pose>0 0 0.5 0 0 0</pose><collision name='c'>{geometry}</collision>"
        f"<visual name='v'>{geometry}</visual></link></model></sdf>"
    )


def _wall_world(tmp_path, uri):
    path = tmp_path / "wall.world"
    path.write_text(
        f"<?xml version='1.0'?><sdf version='1.6'><world name='w'>"
        f"<include><uri>model://ground_plane</uri></include>"
        f"<include><uri>{uri}</uri><pose>{WALL_X} 0 0 0 0 0</pose></include></world></sdf>"
    )
    return path


def _range_ahead(sim: Simulator) -> tuple[float, float]:
    """The scan's beam straight ahead and the distance the geometry gives for it."""
    scans = []
    sim.subscribe("/scan", scans.append)
    sim.run_until(0.1)
    scan = scans[-1]
    origin, _ = laser_pose(sim)
    beam = round(-scan.angle_min / scan.angle_increment)
    assert abs(scan.angle_min + beam * scan.angle_increment) < 1e-6
    return scan.ranges[beam], WALL_X - WALL_THICKNESS / 2 - origin[0]


def test_a_world_finds_model_uris_inside_a_package_on_the_path(tmp_path, monkeypatch):
    write_package_xml(tmp_path / "ws" / "its_pkg", "its_pkg")
    _box_wall_model(tmp_path / "ws" / "its_pkg" / "models")
    world = _wall_world(tmp_path, "model://its_pkg/models/box_wall")
    monkeypatch.setenv("ROS_PACKAGE_PATH", str(tmp_path / "ws"))
    with Simulator(world=str(world), camera=False, sensor_noise=False) as sim:
        measured, expected = _range_ahead(sim)
    assert expected == pytest.approx(WALL_X - WALL_THICKNESS / 2 - 0.265, abs=0.05)
    assert measured == pytest.approx(expected, abs=1e-3)


def test_a_world_finds_models_a_package_exports(tmp_path, monkeypatch):
    write_package_xml(
        tmp_path / "ws" / "its_pkg", "its_pkg", export='<gazebo_ros gazebo_model_path="${prefix}/models"/>'
    )
    _box_wall_model(tmp_path / "ws" / "its_pkg" / "models")
    world = _wall_world(tmp_path, "model://box_wall")
    monkeypatch.setenv("ROS_PACKAGE_PATH", str(tmp_path / "ws"))
    with Simulator(world=str(world), camera=False, lidar=False) as sim:
        geom = sim.model.geom("box_wall::l/c")
        assert sim.data.geom_xpos[geom.id] == pytest.approx([WALL_X, 0.0, 0.5])
    monkeypatch.delenv("ROS_PACKAGE_PATH")
    with pytest.raises(Exception, match="box_wall.*--package-path"):
        Simulator(world=str(world), camera=False, lidar=False)


def test_without_the_package_path_the_world_names_the_fix(tmp_path):
    _box_wall_model(tmp_path / "ws" / "its_pkg" / "models")
    world = _wall_world(tmp_path, "model://its_pkg/models/box_wall")
    with pytest.raises(Exception) as err:
        Simulator(world=str(world), camera=False, lidar=False)
    assert "its_pkg" in str(err.value) and "--package-path" in str(err.value) and "\n" not in str(err.value)
