"""The ROS 2 bridge's parts that need no ROS 2: the QoS table, the service mapping, the generated packages' sources,
the environment of ROS processes, the one-line errors of --ros2 and ros2-env."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

from racecar_sim.bridges.ros2 import environment, qos, services, types
from racecar_sim.bridges.topic_map import IDENTITY
from racecar_sim.runtime import Simulator

# the subscriber profiles users write (rclpy's definitions): a plain depth, qos_profile_sensor_data, a latched reader
DEFAULT_SUB = {"reliability": "reliable", "durability": "volatile"}
SENSOR_SUB = {"reliability": "best_effort", "durability": "volatile"}
LATCHED_SUB = {"reliability": "reliable", "durability": "transient_local"}
RANK = {"best_effort": 0, "reliable": 1, "volatile": 0, "transient_local": 1}


def _matches(offered: dict, requested: dict) -> bool:
    """DDS's request-offered rule: the writer offers at least the reader's reliability and durability."""
    return all(RANK[offered[policy]] >= RANK[requested[policy]] for policy in ("reliability", "durability"))


@pytest.mark.parametrize(
    "topic, msgtype, latched",
    [
        ("/scan", "sensor_msgs/msg/LaserScan", False),
        ("/camera/zed/rgb/image_rect_color", "sensor_msgs/msg/Image", False),
        ("/camera/zed/rgb/camera_info", "sensor_msgs/msg/CameraInfo", False),
        ("/imu", "sensor_msgs/msg/Imu", False),
        ("/vesc/odom", "nav_msgs/msg/Odometry", False),
        ("/tf", "tf2_msgs/msg/TFMessage", False),
        ("/clock", "rosgraph_msgs/msg/Clock", False),
        ("/tf_static", "tf2_msgs/msg/TFMessage", True),
        ("/map", "nav_msgs/msg/OccupancyGrid", True),
        ("/robot_description", "std_msgs/msg/String", True),
    ],
)
def test_every_published_topic_serves_default_and_sensor_data_subscribers(topic, msgtype, latched) -> None:
    offered = qos.profile(topic, msgtype, latched)
    assert _matches(offered, DEFAULT_SUB) and _matches(offered, SENSOR_SUB)
    assert _matches(offered, LATCHED_SUB) == latched  # late joiners get what is latched, and only that
    if latched or topic == "/clock":
        assert offered["depth"] == 1  # readers keep the newest
    assert qos.profile("/tf", "tf2_msgs/msg/TFMessage")["depth"] == 100  # tf2_ros's broadcaster


def test_command_topics_take_default_and_sensor_data_publishers() -> None:
    requested = qos.command_profile()
    default_pub = {"reliability": "reliable", "durability": "volatile"}
    sensor_pub = {"reliability": "best_effort", "durability": "volatile"}
    latched_pub = {"reliability": "reliable", "durability": "transient_local"}
    for publisher in (default_pub, sensor_pub, latched_pub):
        assert _matches(publisher, requested)


def test_f1tenth_names_carry_gym_bridges_qos() -> None:
    from racecar_sim.bridges.f1tenth import F1tenthInterface

    sim = Simulator(world="empty", camera=False)
    try:
        f1 = F1tenthInterface(sim)
        # gym_bridge.py: create_publisher(LaserScan, ego_scan_topic, 10) and the odometry alike
        for ros_topic in ("/scan", "/ego_racecar/odom"):
            assert qos.profile(ros_topic, "x/msg/Y", False, f1.qos_name(ros_topic)) == {
                "reliability": "reliable",
                "durability": "volatile",
                "depth": 10,
            }
        assert f1.qos_name("/racecar/joint_states") is None
        assert f1.ros_name("/robot_description") == "/ego_robot_description"  # gym_bridge_launch.py's remapping
    finally:
        sim.close()


def _call(sim: Simulator, name: str, request: dict) -> dict:
    service = services.offered(sim.bus.services())[name]
    return service.response(sim.bus.call(service.sim_name, service.request(request)), request)


def test_gazebo_ros2_services_map_onto_the_sims_gazebo_api() -> None:
    with Simulator(world="empty", camera=False) as sim:
        offered = services.offered(sim.bus.services())
        for name, srv in (
            ("/spawn_entity", "gazebo_msgs/srv/SpawnEntity"),
            ("/delete_entity", "gazebo_msgs/srv/DeleteEntity"),
            ("/get_entity_state", "gazebo_msgs/srv/GetEntityState"),
            ("/set_entity_state", "gazebo_msgs/srv/SetEntityState"),
            ("/reset_simulation", "std_srvs/srv/Empty"),
            ("/reset_world", "std_srvs/srv/Empty"),
            ("/pause_physics", "std_srvs/srv/Empty"),
            ("/unpause_physics", "std_srvs/srv/Empty"),
            ("/racecar/controller_manager/switch_controller", "controller_manager_msgs/srv/SwitchController"),
        ):
            assert offered[name].ros_type == srv
        sim.run_for(0.2)
        state = _call(sim, "/get_entity_state", {"name": "racecar", "reference_frame": ""})
        assert state["success"] and state["state"]["name"] == "racecar"
        assert state["state"]["pose"]["position"]["z"] == pytest.approx(sim.car.state.base_pose()[0][2])
        assert state["header"]["stamp"] == {"sec": 0, "nanosec": 200_000_000}
        moved = _call(
            sim,
            "/set_entity_state",
            {"state": {"name": "racecar", "pose": {"position": {"x": 2.0, "y": 1.0, "z": 0.05}}}},
        )
        assert moved == {"success": True}
        assert sim.car.state.base_pose()[0][:2] == pytest.approx([2.0, 1.0])
        missing = _call(sim, "/delete_entity", {"name": "no_such_model"})
        assert missing["success"] is False and "no_such_model" in missing["status_message"]
        assert _call(sim, "/pause_physics", {}) == {} and sim.paused
        assert _call(sim, "/unpause_physics", {}) == {} and not sim.paused


def test_controller_manager_services_speak_ros2_control() -> None:
    with Simulator(world="empty", camera=False) as sim:
        cm = "/racecar/controller_manager"
        listed = {c["name"]: c for c in _call(sim, f"{cm}/list_controllers", {})["controller"]}
        wheel = listed["left_rear_wheel_velocity_controller"]
        assert wheel["state"] == "active" and len(wheel["claimed_interfaces"]) == 1
        assert wheel["claimed_interfaces"][0].endswith("/effort")
        assert listed["joint_state_controller"]["claimed_interfaces"] == []
        off = _call(
            sim,
            f"{cm}/switch_controller",
            {
                "activate_controllers": [],
                "deactivate_controllers": ["left_rear_wheel_velocity_controller"],
                "strictness": 2,
                "activate_asap": False,
                "timeout": {"sec": 1, "nanosec": 0},
            },
        )
        assert off == {"ok": True, "message": ""}
        listed = {c["name"]: c for c in _call(sim, f"{cm}/list_controllers", {})["controller"]}
        assert listed["left_rear_wheel_velocity_controller"]["state"] == "inactive"
        assert listed["left_rear_wheel_velocity_controller"]["claimed_interfaces"] == []
        types_ = _call(sim, f"{cm}/list_controller_types", {})
        assert len(types_["types"]) == len(types_["base_classes"]) > 0
        assert _call(sim, f"{cm}/unload_controller", {"name": "left_rear_wheel_velocity_controller"}) == {"ok": True}
        assert _call(sim, f"{cm}/load_controller", {"name": "left_rear_wheel_velocity_controller"}) == {"ok": True}


def test_generated_packages_are_the_sims_messages_with_the_ros2_services() -> None:
    sources = types.sources()
    assert set(sources) == {"ackermann_msgs", "control_msgs", "controller_manager_msgs", "gazebo_msgs", "tf2_msgs"}
    assert set(sources["ackermann_msgs"]) == {"msg/AckermannDrive.msg", "msg/AckermannDriveStamped.msg"}
    assert {"srv/SpawnEntity.srv", "srv/DeleteEntity.srv", "srv/GetEntityState.srv", "srv/SetEntityState.srv"} <= set(
        sources["gazebo_msgs"]
    )
    assert {"msg/ModelStates.msg", "msg/LinkStates.msg", "msg/ModelState.msg", "msg/EntityState.msg"} <= set(
        sources["gazebo_msgs"]
    )
    manager = sources["controller_manager_msgs"]
    assert "msg/HardwareInterfaceResources.msg" not in manager  # ROS 1 only
    assert "claimed_interfaces" in manager["msg/ControllerState.msg"]  # the ros2_control form, not ROS 1's
    assert "activate_controllers" in manager["srv/SwitchController.srv"]
    assert types._dependencies("gazebo_msgs", sources["gazebo_msgs"]) == ["geometry_msgs", "std_msgs"]
    assert types._dependencies("controller_manager_msgs", manager) == ["builtin_interfaces"]
    assert types._dependencies("tf2_msgs", sources["tf2_msgs"]) == ["geometry_msgs"]


def _ros(distro: str = "jazzy") -> environment.RosPython:
    return environment.RosPython("/nowhere/bin/python", distro, "3.11", "/nowhere", "/nowhere/rclpy", True)


def test_prefix_is_keyed_by_distro_python_and_definitions(tmp_path, monkeypatch) -> None:
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    jazzy, kilted = types.prefix_path(_ros("jazzy")), types.prefix_path(_ros("kilted"))
    assert jazzy.parent == tmp_path / "racecar-sim" / "ros2"
    assert jazzy.name.startswith("jazzy-py3.11-") and kilted.name.startswith("kilted-py3.11-")
    assert types.built(_ros()) is None
    with pytest.raises(Exception, match="ros2-env --build"):
        types.require(_ros())


def test_loopback_unless_the_user_opened_the_network() -> None:
    jazzy = environment.loopback_variables("jazzy", {})
    assert jazzy["ROS_AUTOMATIC_DISCOVERY_RANGE"] == "LOCALHOST"
    assert jazzy["FASTRTPS_DEFAULT_PROFILES_FILE"] == str(environment.FASTDDS_PROFILE)
    assert environment.FASTDDS_PROFILE.is_file() and "127.0.0.1" in environment.FASTDDS_PROFILE.read_text()
    assert environment.loopback_variables("humble", {})["ROS_LOCALHOST_ONLY"] == "1"
    assert environment.loopback_variables("jazzy", {"ROS_AUTOMATIC_DISCOVERY_RANGE": "SUBNET"}) == {}
    assert environment.loopback_variables("humble", {"ROS_LOCALHOST_ONLY": "0"}) == {}
    profile = environment.loopback_variables("jazzy", {"FASTRTPS_DEFAULT_PROFILES_FILE": "/mine.xml"})
    assert "FASTRTPS_DEFAULT_PROFILES_FILE" not in profile and profile["ROS_AUTOMATIC_DISCOVERY_RANGE"] == "LOCALHOST"


def test_another_interpreters_process_does_not_inherit_the_wheels_bootstrap(monkeypatch) -> None:
    own_lib = os.path.join(sys.prefix, "lib")
    env = {"_ROS_WHEELS_BOOTSTRAP_COMPLETE": "1", "LD_LIBRARY_PATH": f"{own_lib}:/opt/other/lib", "X": "1"}
    cleaned = environment.clean_environment("/elsewhere/venv/bin/python", env)
    assert "_ROS_WHEELS_BOOTSTRAP_COMPLETE" not in cleaned
    assert cleaned["LD_LIBRARY_PATH"] == "/opt/other/lib" and cleaned["X"] == "1"
    assert environment.clean_environment("/elsewhere/venv/bin/python", {"LD_LIBRARY_PATH": "/opt/ros/lib"}) == {
        "LD_LIBRARY_PATH": "/opt/ros/lib"  # a sourced ROS install's: kept
    }


def test_identity_topic_map_is_the_default() -> None:
    from racecar_sim.bridges.ros2.bridge import Ros2Bridge

    assert Ros2Bridge.__init__.__defaults__ is not None and IDENTITY in Ros2Bridge.__init__.__defaults__


def _cli(*args: str, env: dict[str, str]) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "racecar_sim", *args], capture_output=True, text=True, env=env, timeout=120
    )


def _no_ros_env(**extra: str) -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if not k.startswith("ROS_") and k != "RACECAR_SIM_ROS2_PYTHON"}
    env.update(extra)
    return env


@pytest.mark.parametrize("command", [["run", "--duration", "1"], ["launch", "x.launch"], ["teleop"]])
def test_ros2_without_rclpy_is_one_line(command: list[str], tmp_path) -> None:
    env = _no_ros_env(RACECAR_SIM_ROS2_PYTHON=sys.executable)  # a Python without rclpy
    if command[0] == "launch":
        command = ["launch", "--ros2", str(tmp_path / "none.launch")]
        (tmp_path / "none.launch").write_text("<launch/>")
    else:
        command = [*command, "--ros2"]
    done = _cli(*command, env=env)
    assert done.returncode == 2, done.stderr
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1, done.stderr
    assert "RACECAR_SIM_ROS2_PYTHON" in lines[0] and "cannot import rclpy" in lines[0]
    assert 'pip install -e ".[ros2]"' in lines[0]


def test_ros2_with_no_ros_anywhere_names_what_to_install() -> None:
    import importlib.util

    if importlib.util.find_spec("rclpy") is not None:
        pytest.skip("this interpreter has rclpy (the [ros2] extra)")
    done = _cli("run", "--ros2", "--duration", "1", env=_no_ros_env())
    assert done.returncode == 2
    assert done.stderr.strip() == (
        f"racecar-sim: error: --ros2 needs ROS 2 (rclpy on Fast DDS); install it: {environment.INSTALL}"
    )
    done = _cli("ros2-env", env=_no_ros_env())
    assert done.returncode == 2 and len(done.stderr.strip().splitlines()) == 1 and done.stdout == ""


def test_a_bad_ros_domain_id_is_one_line() -> None:
    done = _cli("run", "--ros2", "--duration", "1", env=_no_ros_env(ROS_DOMAIN_ID="twelve"))
    assert done.returncode == 2
    assert done.stderr.strip() == "racecar-sim: error: --ros2: ROS_DOMAIN_ID='twelve' is not a domain id (0 to 232)"
    assert environment.domain_id({"ROS_DOMAIN_ID": "42"}) == 42
    assert environment.domain_id({}) == 0
