"""Launch files run in the sim: a fleet from <group ns> and spawn_model, command-line args, the original
racecar.launch -> racecar_control.launch -> mux.launch chain, a user's own mux YAMLs, and a launch without a
servo node."""

from __future__ import annotations

import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from racecar_sim.description import package_path
from racecar_sim.launch import LaunchRun, load_launch, map_plan
from racecar_sim.msgs import AckermannDrive, AckermannDriveStamped, Float64, Header

CONTROLLERS = (
    "left_rear_wheel_velocity_controller right_rear_wheel_velocity_controller "
    "left_front_wheel_velocity_controller right_front_wheel_velocity_controller "
    "left_steering_hinge_position_controller right_steering_hinge_position_controller joint_state_controller"
)
GROUND_WORLD = """<?xml version="1.0"?>
<sdf version="1.4"><world name="flat">
  <model name="ground_plane"><static>true</static><link name="link"><collision name="collision">
    <geometry><plane><normal>0 0 1</normal><size>50 50</size></plane></geometry></collision></link></model>
</world></sdf>
"""
# racecar_control.launch of the original, element for element
RACECAR_CONTROL = f"""<?xml version='1.0'?>
<launch>
  <rosparam file="$(find racecar_control)/config/racecar_control.yaml" command="load"/>
  <node name="controller_manager" pkg="controller_manager" type="spawner" respawn="false"
        output="screen" ns="/racecar" args="{CONTROLLERS}"/>
  <node name="robot_state_publisher" pkg="robot_state_publisher" type="robot_state_publisher" respawn="false"
        output="screen">
    <remap from="/joint_states" to="/racecar/joint_states" />
  </node>
  <node pkg="racecar_control" type="servo_commands.py" name="servo_commands" output="screen">
    <remap from="/racecar/ackermann_cmd_mux/output" to="/vesc/low_level/ackermann_cmd_mux/output"/>
  </node>
  <node pkg="racecar_gazebo" name="gazebo_odometry_node" type="gazebo_odometry.py"/>
</launch>
"""
# racecar_gazebo's racecar.launch of the original, element for element
RACECAR = """<?xml version="1.0"?>
<launch>
  <arg name="world_name" default="racecar" />
  <arg name="gui" default="true" />
  <arg name="run_camera" default="false"/>
  <include file="$(find gazebo_ros)/launch/empty_world.launch">
    <arg name="world_name" value="$(find racecar_gazebo)/worlds/$(arg world_name).world"/>
    <arg name="gui" value="$(arg gui)"/>
  </include>
  <param name="robot_description" command="$(find xacro)/xacro '$(find racecar_description)/urdf/racecar.xacro'" />
  <node name="racecar_spawn" pkg="gazebo_ros" type="spawn_model" output="screen"
        args="-urdf -param robot_description -model racecar -z 0.05" />
  <include file="$(find racecar_control)/launch/racecar_control.launch" ns="/"/>
  <arg name="racecar_version" default="racecar-v2" />
  <include file="$(find racecar)/launch/mux.launch" ns="vesc" />
  <node name="better_odom" pkg="topic_tools" type="relay" args="/vesc/odom /pf/pose/odom" />
</launch>
"""
CAR = f"""<?xml version="1.0"?>
<launch>
  <arg name="x" default="0.0"/>
  <arg name="speed"/>
  <param name="robot_description" command="$(find xacro)/xacro '$(find racecar_description)/urdf/racecar.xacro'"/>
  <node name="spawn" pkg="gazebo_ros" type="spawn_model" args="-urdf -param robot_description -x $(arg x) -z 0.05"/>
  <rosparam file="$(find racecar_control)/config/racecar_control.yaml" command="load"/>
  <node name="controller_manager" pkg="controller_manager" type="spawner" ns="racecar" args="{CONTROLLERS}"/>
  <node name="robot_state_publisher" pkg="robot_state_publisher" type="robot_state_publisher">
    <remap from="joint_states" to="racecar/joint_states"/>
  </node>
  <node pkg="racecar_control" type="servo_commands.py" name="servo_commands">
    <remap from="/racecar/ackermann_cmd_mux/output" to="vesc/low_level/ackermann_cmd_mux/output"/>
  </node>
  <node pkg="racecar_gazebo" type="gazebo_odometry.py" name="gazebo_odometry_node"/>
  <include file="$(find racecar)/launch/mux.launch" ns="vesc"/>
  <node pkg="racecar_sim" type="constant" name="driver"><param name="speed" value="$(arg speed)"/></node>
</launch>
"""
FLEET = """<?xml version="1.0"?>
<launch>
  <arg name="x1" default="0.0"/>
  <arg name="speed" default="1.0"/>
  <include file="$(find gazebo_ros)/launch/empty_world.launch">
    <arg name="world_name" value="empty"/>
    <arg name="gui" value="false"/>
  </include>
  <group ns="car1">
    <include file="$(dirname)/car.launch">
      <arg name="x" value="$(arg x1)"/><arg name="speed" value="$(arg speed)"/>
    </include>
  </group>
  <group ns="car2">
    <include file="$(dirname)/car.launch">
      <arg name="x" value="$(eval x1 - 1.5)"/><arg name="speed" value="$(eval speed / 2)"/>
    </include>
  </group>
</launch>
"""


def package(root: Path, name: str, files: dict[str, str]) -> Path:
    folder = root / name
    folder.mkdir(parents=True)
    (folder / "package.xml").write_text(
        f"<package format='2'><name>{name}</name><version>1.0.0</version>"
        "<description>d</description><maintainer email='a@b.c'>m</maintainer>"
        "<license>BSD</license></package>\n"
    )
    for relative, text in files.items():
        (folder / relative).parent.mkdir(parents=True, exist_ok=True)
        (folder / relative).write_text(text)
    return folder


@pytest.fixture
def fleet_launch(tmp_path: Path) -> Path:
    (tmp_path / "car.launch").write_text(CAR)
    (tmp_path / "fleet.launch").write_text(FLEET)
    return tmp_path / "fleet.launch"


@pytest.fixture
def original_packages(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """racecar_gazebo and racecar_control as in the original repository (launch files, a world, the YAML) on
    ROS_PACKAGE_PATH; gazebo_ros, racecar, ackermann_cmd_mux, xacro, ... are the sim's stand-ins."""
    src = tmp_path / "src"
    package(
        src,
        "racecar_gazebo",
        {
            "launch/racecar.launch": RACECAR,
            "worlds/flat.world": GROUND_WORLD,
            "launch/racecar_flat.launch": '<launch><include file="$(find racecar_gazebo)/launch/'
            'racecar.launch"><arg name="world_name" value="flat"/></include></launch>',
        },
    )
    package(
        src,
        "racecar_control",
        {
            "launch/racecar_control.launch": RACECAR_CONTROL,
            "config/racecar_control.yaml": (
                package_path("racecar_control") / "config/racecar_control.yaml"
            ).read_text(),
        },
    )
    monkeypatch.setenv("ROS_PACKAGE_PATH", str(src))
    return src


def drive(topic: str, speed: float = 1.0, steering: float = 0.0) -> AckermannDriveStamped:
    return AckermannDriveStamped(Header(), AckermannDrive(steering_angle=steering, speed=speed))


def run_with_commands(run: LaunchRun, topic: str, duration: float, speed: float = 1.0) -> None:
    sim = run.sim
    sim.scheduler.every(20.0, lambda t: sim.publish(topic, drive(topic, speed)), "test driver")
    sim.run_until(duration)


def test_groups_with_a_spawn_each_run_two_namespaced_cars(fleet_launch):
    setup = map_plan(load_launch(fleet_launch, {"x1": "2.0"}), camera=False)
    with LaunchRun(setup) as run:
        sim = run.sim
        assert [car.model_name for car in sim.cars] == ["car1", "car2"]
        starts = {car.name: car.state.base_pose()[0][:2].copy() for car in sim.cars}
        assert starts["car1"] == pytest.approx([2.0, 0.0], abs=1e-6)  # -x $(arg x1)
        assert starts["car2"] == pytest.approx([0.5, 0.0], abs=1e-6)  # -x $(eval x1 - 1.5)
        scans = {ns: [] for ns in ("car1", "car2")}
        for ns, received in scans.items():
            sim.subscribe(f"/{ns}/scan", received.append)  # the lidar casts its rays only for a listener
        sim.run_until(2.0)
        for ns in ("car1", "car2"):
            assert len(scans[ns]) == 80 and scans[ns][0].header.frame_id == f"{ns}/laser"  # 40 Hz
            assert sim.bus.count(f"/{ns}/vesc/odom") == 40 and sim.bus.count(f"/{ns}/racecar/joint_states") == 100
            assert sim.bus.count(f"/{ns}/vesc/low_level/ackermann_cmd_mux/output") > 0
        assert "/scan" not in sim.bus.topics() and "/pf/pose/odom" not in sim.bus.topics()  # no better_odom relay
        moved = {car.name: car.state.base_pose()[0][0] - starts[car.name][0] for car in sim.cars}
    # each car's own constant driver: car1 at 1 m/s, car2 at half of it ($(eval speed / 2))
    assert 1.3 < moved["car1"] < 2.0 and 0.6 < moved["car2"] < 1.0


def test_command_line_args_override_defaults(fleet_launch, tmp_path):
    result = subprocess.run(
        [
            sys.executable,
            "-m",
            "racecar_sim",
            "launch",
            str(fleet_launch),
            "x1:=3",
            "speed:=0.5",
            "--duration",
            "1",
            "--no-camera",
            "--no-lidar",
            "--out",
            str(tmp_path / "out"),
        ],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert result.returncode == 0, result.stderr
    xs = {m[0]: float(m[1]) for m in re.findall(r"^(car\d)\s+x ([-\d.]+) m", result.stdout, re.M)}
    assert 3.1 < xs["car1"] < 3.5 and 1.5 < xs["car2"] < 1.8
    assert (tmp_path / "out" / "run.mcap").stat().st_size > 0


def test_the_original_racecar_launch_chain(original_packages):
    plan = load_launch(original_packages / "racecar_gazebo" / "launch" / "racecar_flat.launch")
    setup = map_plan(plan, camera=False)
    assert setup.world.world.endswith("racecar_gazebo/worlds/flat.world") and not setup.world.paused
    assert setup.relays == [("/vesc/odom", "/pf/pose/odom")]  # better_odom; the mux relays went into the chain
    with LaunchRun(setup) as run:
        sim = run.sim
        car = sim.car
        assert car.model_name == "racecar" and car.servo.input_topic == "/vesc/low_level/ackermann_cmd_mux/output"
        assert [c.name for c in car.controller_manager.list_controllers()] == CONTROLLERS.split()
        assert all(c.state == "running" for c in car.controller_manager.list_controllers())
        run_with_commands(run, "/vesc/ackermann_cmd_mux/input/navigation", 2.0)
        x = car.state.base_pose()[0][0]
        assert 1.3 < x < 2.0
        assert sim.bus.count("/pf/pose/odom") == sim.bus.count("/vesc/odom") == 40
        assert sim.bus.count("/vesc/high_level/ackermann_cmd_mux/input/default") == 12  # rostopic pub -r 6
        assert car.chain.in_control() == "Navigation"
        assert sim.bus.count("/tf_static") >= 1 and sim.bus.count("/racecar/joint_states") == 100


def test_a_users_own_mux_yamls_are_read(original_packages):
    """The user's `racecar` package on the path wins over the stand-in: its low-level mux listens on input/joystick
    for teleop, and that input drives the car."""
    stand_in = Path(__file__).resolve().parents[1] / "src/racecar_sim/launch/data/racecar"
    own = original_packages / "racecar"
    shutil.copytree(stand_in, own)
    low = own / "config" / "racecar-v2" / "low_level_mux.yaml"
    low.write_text(low.read_text().replace("input/teleop", "input/joystick"))
    setup = map_plan(load_launch(original_packages / "racecar_gazebo" / "launch" / "racecar_flat.launch"), camera=False)
    assert str(own) in setup.cars[0].plan.mux["muxes"]["/vesc/low_level/ackermann_cmd_mux"]
    with LaunchRun(setup) as run:
        run_with_commands(run, "/vesc/low_level/ackermann_cmd_mux/input/joystick", 1.0, speed=-1.0)
        assert run.sim.car.chain.in_control() == "Teleoperation"
        assert run.sim.car.state.base_pose()[0][0] < -0.5


def test_a_launch_without_servo_commands_has_no_sim_servo(original_packages):
    control = original_packages / "racecar_control" / "launch" / "racecar_control.launch"
    text = control.read_text()
    control.write_text(
        re.sub(r'  <node pkg="racecar_control" type="servo_commands.py".*?</node>\n', "", text, flags=re.S)
    )
    setup = map_plan(load_launch(original_packages / "racecar_gazebo" / "launch" / "racecar_flat.launch"), camera=False)
    with LaunchRun(setup) as run:
        sim = run.sim
        assert sim.car.servo is None
        run_with_commands(run, "/vesc/ackermann_cmd_mux/input/navigation", 0.5)
        assert sim.bus.count("/vesc/low_level/ackermann_cmd_mux/output") > 0
        assert sim.bus.count("/racecar/left_rear_wheel_velocity_controller/command") == 0
        assert abs(sim.car.state.base_pose()[0][0]) < 0.01  # nothing turns the mux output into wheel commands
        # what a user's own servo node would publish drives the car
        wheels = [
            f"/racecar/{side}_{end}_wheel_velocity_controller/command"
            for side in ("left", "right")
            for end in ("rear", "front")
        ]
        sim.scheduler.every(20.0, lambda t: [sim.publish(w, Float64(10.0)) for w in wheels], "user servo")
        sim.run_until(1.5)
        assert sim.car.state.base_pose()[0][0] > 0.3


def test_sim_drivers_and_keyboard_teleop_from_the_launch(tmp_path):
    (tmp_path / "drivers.launch").write_text(
        f"""<launch>
  <param name="robot_description" command="$(find xacro)/xacro '$(find racecar_description)/urdf/racecar.xacro'"/>
  <node name="spawn" pkg="gazebo_ros" type="spawn_model" args="-urdf -param robot_description"/>
  <rosparam file="$(find racecar_control)/config/racecar_control.yaml" command="load"/>
  <node name="controller_manager" pkg="controller_manager" type="spawner" ns="/racecar" args="{CONTROLLERS}"/>
  <node pkg="racecar_control" type="servo_commands.py" name="servo_commands">
    <remap from="/racecar/ackermann_cmd_mux/output" to="/vesc/low_level/ackermann_cmd_mux/output"/>
  </node>
  <include file="$(find racecar)/launch/mux.launch" ns="vesc"/>
  <node pkg="racecar_sim" type="wall_follow" name="follower"><param name="side" value="left"/>
    <param name="distance" value="0.7"/></node>
  <node pkg="racecar_control" type="keyboard_teleop.py" name="keyboard_teleop"/>
</launch>"""
    )
    setup = map_plan(load_launch(tmp_path / "drivers.launch"), camera=False, lidar=False)
    assert setup.teleop_topics == ["/vesc/ackermann_cmd_mux/input/teleop"]
    with LaunchRun(setup) as run:
        (follower,) = run.drivers
        assert follower.config.side == "left" and follower.config.distance == 0.7  # its ~private params
        assert run.sim.car.odometry is None and run.sim.car.robot_state is None  # not in the launch: not run
        run.teleops[0].key("s")  # keyboard_teleop.py's reverse
        run.sim.run_until(0.4)  # within the key's hold time
        assert run.sim.car.chain.in_control() == "Teleoperation"
        assert run.sim.car.state.base_pose()[0][0] < -0.02


def test_a_launch_with_a_vehicle_set_gives_every_car_its_tyres(fleet_launch):
    setup = map_plan(load_launch(fleet_launch), vehicle="f1tenth")
    assert [car.vehicle.name for car in setup.cars] == ["f1tenth"] * len(setup.cars) and len(setup.cars) == 2
    with LaunchRun(setup) as run:
        sim = run.sim
        tables = [sim.model.numeric(i).name for i in range(sim.model.nnumeric)]
        assert sorted(t for t in tables if t.endswith("tyre_table")) == ["car1/tyre_table", "car2/tyre_table"]
        sim.run_until(0.5)
