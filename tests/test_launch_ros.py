"""`--ros`: nodes the sim has no equivalent for start as real ROS 1 processes, with the launch's parameters on the
parameter server, their private params and remaps (Debian's ROS 1; skipped where it is not installed)."""

from __future__ import annotations

import time
from pathlib import Path

import pytest

from racecar_sim.bridges.ros1 import ros_available
from racecar_sim.bridges.ros1.environment import ros_environment
from racecar_sim.bridges.ros1.master import Master
from racecar_sim.launch import LaunchRun, load_launch, map_plan
from ros_package_helpers import write_package_xml

pytestmark = pytest.mark.skipif(
    not (Path("/usr/bin/roscore").exists() and ros_available()),
    reason="ROS 1 is not installed (apt-get install ros-core python3-rospy ...)",
)
# a user's driver node: publishes its private ~speed on a relative topic the launch remaps onto the mux input
DRIVER = """#!/usr/bin/env python3
import rospy
from ackermann_msgs.msg import AckermannDriveStamped
rospy.init_node("driver")
speed = rospy.get_param("~speed")
pub = rospy.Publisher("drive", AckermannDriveStamped, queue_size=1)
rate = rospy.Rate(20)
while not rospy.is_shutdown():
    msg = AckermannDriveStamped()
    msg.drive.speed = speed
    pub.publish(msg)
    rate.sleep()
"""
LAUNCH = """<launch>
  <include file="$(find gazebo_ros)/launch/empty_world.launch"><arg name="gui" value="false"/></include>
  <param name="robot_description" command="$(find xacro)/xacro '$(find racecar_description)/urdf/racecar.xacro'"/>
  <node name="racecar_spawn" pkg="gazebo_ros" type="spawn_model" args="-urdf -param robot_description -model racecar"/>
  <rosparam file="$(find racecar_control)/config/racecar_control.yaml" command="load"/>
  <node name="controller_manager" pkg="controller_manager" type="spawner" ns="/racecar"
        args="left_rear_wheel_velocity_controller right_rear_wheel_velocity_controller
              left_front_wheel_velocity_controller right_front_wheel_velocity_controller
              left_steering_hinge_position_controller right_steering_hinge_position_controller
              joint_state_controller"/>
  <node pkg="racecar_control" type="servo_commands.py" name="servo_commands">
    <remap from="/racecar/ackermann_cmd_mux/output" to="/vesc/low_level/ackermann_cmd_mux/output"/>
  </node>
  <node pkg="racecar_gazebo" name="gazebo_odometry_node" type="gazebo_odometry.py"/>
  <include file="$(find racecar)/launch/mux.launch" ns="vesc"/>
  <group ns="planning">
    <node pkg="my_driver" type="driver.py" name="driver">
      <param name="speed" value="0.8"/>
      <remap from="drive" to="/vesc/ackermann_cmd_mux/input/navigation"/>
    </node>
  </group>
</launch>
"""


def driver_package(tmp_path: Path) -> None:
    """A user's package `my_driver` under tmp_path/src, its executable scripts/driver.py the DRIVER node."""
    package = tmp_path / "src" / "my_driver"
    (package / "scripts").mkdir(parents=True)
    write_package_xml(package, "my_driver")
    script = package / "scripts" / "driver.py"
    script.write_text(DRIVER)
    script.chmod(0o755)


@pytest.fixture
def master():
    core = Master(None, ros_environment(None, None), port=None)
    yield core
    core.close()


def test_a_users_ros_node_from_the_launch_drives_the_car(master, tmp_path, monkeypatch):
    driver_package(tmp_path)
    (tmp_path / "drive.launch").write_text(LAUNCH)
    monkeypatch.setenv("ROS_PACKAGE_PATH", str(tmp_path / "src"))
    setup = map_plan(load_launch(tmp_path / "drive.launch"), ros=True, camera=False, lidar=False)
    assert [n.full_name for n in setup.ros_nodes] == ["/planning/driver"]
    with LaunchRun(setup, ros=True, master_uri=master.uri) as run:
        sim, bridge = run.sim, run.bridge
        assert bridge.get_param("/planning/driver/speed") == 0.8
        assert bridge.get_param("/racecar/left_rear_wheel_velocity_controller/pid/p") == 1.0
        assert "<robot" in bridge.get_param("/robot_description")
        end = time.monotonic() + 60
        while sim.car.state.base_pose()[0][0] < 0.5 and time.monotonic() < end:
            sim.run_for(0.05)
            time.sleep(0.02)
        assert sim.car.chain.in_control() == "Navigation"
        assert sim.car.state.base_pose()[0][0] >= 0.5


# a launch file with no car, like the original teleop.launch: a node for a sim that already runs, one node whose
# package has no such executable (roslaunch reports it and starts the others)
TELEOP_LAUNCH = """<launch>
  <arg name="speed" default="0.6"/>
  <node pkg="my_driver" type="driver.py" name="teleop">
    <param name="speed" value="$(arg speed)"/>
    <remap from="drive" to="/vesc/ackermann_cmd_mux/input/teleop"/>
  </node>
  <node pkg="my_driver" type="no_such_node" name="missing"/>
</launch>
"""


def test_a_carless_launch_file_joins_a_running_sim(master, tmp_path, monkeypatch):
    import signal
    import subprocess
    import sys

    from racecar_sim.bridges.ros1 import RosBridge
    from racecar_sim.runtime import Simulator

    driver_package(tmp_path)
    (tmp_path / "teleop.launch").write_text(TELEOP_LAUNCH)
    monkeypatch.setenv("ROS_PACKAGE_PATH", str(tmp_path / "src"))
    monkeypatch.setenv("ROS_MASTER_URI", master.uri)
    sim = Simulator(world="empty", lidar=False, camera=False)
    bridge = RosBridge(sim, master.uri)
    launch = None
    try:
        bridge.start()
        launch = subprocess.Popen(
            [
                sys.executable,
                "-m",
                "racecar_sim",
                "launch",
                str(tmp_path / "teleop.launch"),
                "--ros",
                "--duration",
                "60",
                "speed:=0.9",
            ],
            stderr=subprocess.PIPE,
            text=True,
            # SIGINT as a terminal's foreground has it (a shell's background job, a CI runner's for one, starts with
            # it ignored, and an ignored signal stays ignored across exec)
            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
        )
        end = time.monotonic() + 60
        while sim.car.state.base_pose()[0][0] < 0.5 and time.monotonic() < end and launch.poll() is None:
            sim.run_for(0.05)
            time.sleep(0.02)
        assert sim.car.chain.in_control() == "Teleoperation"  # the launched node's commands, through the bridge
        assert sim.car.state.base_pose()[0][0] >= 0.5
        assert bridge.get_param("/teleop/speed") == 0.9  # the command line's arg, on the sim's master
    finally:
        if launch is not None:
            launch.send_signal(signal.SIGINT)
            err = launch.communicate(timeout=30)[1]
        bridge.close()
        sim.close()
    assert launch.returncode in (0, 130)
    # reported in one line, and the other node ran; no traceback of ours (the node's own, on SIGINT, may show)
    assert "cannot launch node /missing (my_driver/no_such_node)" in err and "src/racecar_sim/" not in err
