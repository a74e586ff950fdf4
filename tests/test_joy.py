"""The joystick of the original: joy_node (control/joy.py, a gamepad through pygame's SDL2 joystick in
control/joy_device.py) and joy_teleop.py (control/joy_teleop.py) with racecar/config/racecar-v2/joy_teleop.yaml.

Gamepads here are SDL's own virtual joysticks (SDL_JoystickAttachVirtual, called through ctypes on the SDL library
pygame-ce loaded): SDL then reports their axes, buttons, hats, plugging and unplugging through pygame's event queue
exactly as it does a USB gamepad's.
"""

from __future__ import annotations

import contextlib
import ctypes
import fcntl
import logging
import math
import os
import signal
import struct
import subprocess
import sys
import termios
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from racecar_sim import Simulator
from racecar_sim.control.joy import JOY, JoyNode, JoyNodeConfig, JoyState, joy_axis
from racecar_sim.control.joy_teleop import JoyTeleop, joy_teleop_yaml, load_joy_teleop, parse_commands
from racecar_sim.core.errors import ConfigError
from racecar_sim.description.vehicle import VehicleGeometry
from racecar_sim.launch import LaunchRun, load_launch, map_plan
from racecar_sim.msgs import AckermannDrive, AckermannDriveStamped, Header, Joy
from ros_package_helpers import write_package_xml

TELEOP_INPUT = "/vesc/low_level/ackermann_cmd_mux/input/teleop"
OUTPUT = "/vesc/low_level/ackermann_cmd_mux/output"
NAVIGATION = "/vesc/ackermann_cmd_mux/input/navigation"
STAND_IN = Path(__file__).resolve().parents[1] / "src/racecar_sim/launch/data/racecar"
DEADMAN, SPEED_AXIS, STEER_AXIS = 4, 1, 3  # joy_teleop.yaml: the left bumper, the left stick's y, the right's x
MUX_TIMEOUT, DEFAULT_PERIOD = 0.2, 1 / 6  # low_level_mux.yaml's teleop timeout; mux.launch's default command
# joy_teleop.yaml as it was before the original added its default command (063ef88): a released deadman sends
# nothing, and the mux's timeout hands the car to the default zero command
NO_DEFAULT_YAML = """joy_node:
  deadzone: 0.01
  autorepeat_rate: 20
  coalesce_interval: 0.01
teleop:
  ackermann:
    type: topic
    message_type: ackermann_msgs/AckermannDriveStamped
    topic_name: low_level/ackermann_cmd_mux/input/teleop
    deadman_buttons: [4]
    axis_mappings:
      - {axis: 1, target: drive.speed, scale: 1.5, offset: 0.0}
      - {axis: 3, target: drive.steering_angle, scale: 0.2, offset: 0.0}
"""
# racecar/launch/includes/common/joy_teleop.launch.xml in the original's form (mit-racecar/racecar c9e50d2)
JOY_TELEOP_LAUNCH = """<!-- -*- mode: XML -*- -->
<launch>
  <arg name="racecar_version" />
  <arg name="joy_teleop_config"
       default="$(find racecar)/config/$(arg racecar_version)/joy_teleop.yaml" />

  <rosparam file="$(arg joy_teleop_config)" command="load" />

  <node pkg="joy" type="joy_node" name="joy_node" />

  <node pkg="racecar" type="joy_teleop.py" name="joy_teleop" />

</launch>
"""
CONTROLLERS = (
    "left_rear_wheel_velocity_controller right_rear_wheel_velocity_controller "
    "left_front_wheel_velocity_controller right_front_wheel_velocity_controller "
    "left_steering_hinge_position_controller right_steering_hinge_position_controller joint_state_controller"
)
# the car of racecar_gazebo's racecar.launch, and the joystick in <group ns="vesc"> as racecar-v2-teleop.launch.xml
# has it
CAR_WITH_JOYSTICK = f"""<?xml version="1.0"?>
<launch>
  <arg name="racecar_version" default="racecar-v2" />
  <include file="$(find gazebo_ros)/launch/empty_world.launch"><arg name="gui" value="false"/></include>
  <param name="robot_description" command="$(find xacro)/xacro '$(find racecar_description)/urdf/racecar.xacro'" />
  <node name="racecar_spawn" pkg="gazebo_ros" type="spawn_model" args="-urdf -param robot_description -model racecar"/>
  <rosparam file="$(find racecar_control)/config/racecar_control.yaml" command="load"/>
  <node name="controller_manager" pkg="controller_manager" type="spawner" ns="/racecar" args="{CONTROLLERS}"/>
  <node pkg="racecar_control" type="servo_commands.py" name="servo_commands">
    <remap from="/racecar/ackermann_cmd_mux/output" to="/vesc/low_level/ackermann_cmd_mux/output"/>
  </node>
  <node pkg="racecar_gazebo" name="gazebo_odometry_node" type="gazebo_odometry.py"/>
  <group ns="vesc">
    <include file="$(find racecar)/launch/includes/common/joy_teleop.launch.xml" >
      <arg name="racecar_version" value="$(arg racecar_version)" />
    </include>
    <include file="$(find racecar)/launch/mux.launch" />
  </group>
</launch>
"""


# --- SDL's virtual gamepads -------------------------------------------------------------------------------
class VirtualPads:
    """SDL virtual joysticks in this process (SDL_JOYSTICK_TYPE_GAMECONTROLLER: 6 axes, 11 buttons, 1 hat, the
    shape of an XInput pad)."""

    def __init__(self) -> None:
        from racecar_sim.control.joy_device import start_sdl

        self.pygame = start_sdl()
        self.sdl = ctypes.CDLL(self._library())
        self.sdl.SDL_JoystickAttachVirtual.restype = ctypes.c_int
        self.sdl.SDL_JoystickAttachVirtual.argtypes = [ctypes.c_int] * 4
        self.sdl.SDL_JoystickDetachVirtual.argtypes = [ctypes.c_int]
        self.sdl.SDL_JoystickFromInstanceID.restype = ctypes.c_void_p
        self.sdl.SDL_JoystickFromInstanceID.argtypes = [ctypes.c_int]
        self.sdl.SDL_JoystickSetVirtualAxis.argtypes = [ctypes.c_void_p, ctypes.c_int, ctypes.c_int16]
        self.sdl.SDL_JoystickSetVirtualButton.argtypes = [ctypes.c_void_p, ctypes.c_int, ctypes.c_uint8]
        self.sdl.SDL_JoystickSetVirtualHat.argtypes = [ctypes.c_void_p, ctypes.c_int, ctypes.c_uint8]
        self.attached: list[int] = []

    @staticmethod
    def _library() -> str:
        """The SDL2 library pygame loaded (the same copy: SDL's state lives in it)."""
        with open("/proc/self/maps") as maps:
            for line in maps:
                path = line.split()[-1]
                if "libSDL2-" in path or path.endswith("libSDL2-2.0.so.0"):
                    return path
        pytest.skip("pygame's SDL2 library is not mapped in this process")

    def attach(self) -> int:
        index = self.sdl.SDL_JoystickAttachVirtual(1, 6, 11, 1)
        assert index >= 0
        self.attached.append(index)
        return index

    def detach(self, index: int) -> None:
        self.sdl.SDL_JoystickDetachVirtual(index)
        self.attached.remove(index)

    def set(
        self,
        instance_id: int,
        axes: dict[int, int] | None = None,
        buttons: dict[int, int] | None = None,
        hat: int | None = None,
    ) -> None:
        """Raw values as a driver reports them: axes -32768..32767 (stick up / left negative), buttons 0/1, the hat
        as SDL_HAT_* bits (1 up, 2 right, 4 down, 8 left)."""
        pad = self.sdl.SDL_JoystickFromInstanceID(instance_id)
        assert pad
        for axis, value in (axes or {}).items():
            assert self.sdl.SDL_JoystickSetVirtualAxis(pad, axis, value) == 0
        for button, value in (buttons or {}).items():
            assert self.sdl.SDL_JoystickSetVirtualButton(pad, button, value) == 0
        if hat is not None:
            assert self.sdl.SDL_JoystickSetVirtualHat(pad, 0, hat) == 0

    def close(self) -> None:
        for index in reversed(self.attached):
            self.sdl.SDL_JoystickDetachVirtual(index)
        self.pygame.event.clear()


@pytest.fixture
def pads():
    pytest.importorskip("pygame")
    if not sys.platform.startswith("linux"):
        pytest.skip("finds pygame's SDL through /proc/self/maps")
    virtual = VirtualPads()
    virtual.pygame.event.clear()
    yield virtual
    virtual.close()


# --- joy_node's conventions ---------------------------------------------------------------------------------
@pytest.mark.parametrize("raw", [-32768, -32767, -16384, -328, -327, -1, 0, 1, 327, 328, 8192, 32767])
@pytest.mark.parametrize("deadzone", [0.01, 0.05])
def test_an_axis_is_joy_nodes_integer_formula(raw, deadzone):
    """joy_node.cpp: scale = -1 / (1 - deadzone) / 32767; the raw value moved toward 0 by 32767 * deadzone."""
    unscaled = 32767.0 * deadzone
    moved = raw - unscaled if raw > unscaled else raw + unscaled if raw < -unscaled else 0.0
    expected = moved * (-1.0 / (1.0 - deadzone) / 32767.0)
    assert joy_axis(raw / 32767.0, deadzone) == pytest.approx(expected, abs=1e-12)


def test_joy_node_parameters_are_clamped_as_joy_node_does(caplog):
    assert JoyNodeConfig() == JoyNodeConfig(0.05, 0.0, 0.001, "/dev/input/js0", "")
    with caplog.at_level(logging.WARNING, "racecar_sim.joy"):
        assert JoyNodeConfig.from_params({"deadzone": 3276.7}, "f").deadzone == pytest.approx(0.1)
        assert JoyNodeConfig.from_params({"deadzone": 0.95}, "f").deadzone == 0.9
        assert JoyNodeConfig.from_params({"deadzone": -0.1, "autorepeat_rate": -5}, "f").autorepeat_rate == 0.0
    assert len(caplog.records) == 4
    assert JoyNodeConfig.from_params({"autorepeat_rate": "2e1", "dev_name": "pad"}, "f").autorepeat_rate == 20.0
    with pytest.raises(ConfigError, match=r"^launch.xml:3: ~deadzone: expected a finite number, got 'wide'$"):
        JoyNodeConfig.from_params({"deadzone": "wide"}, "launch.xml:3")


def test_the_reader_turns_sdl_events_into_joy_nodes_axes_and_buttons():
    """Synthetic SDL events, posted on pygame's queue as SDL posts a gamepad's, through the reader and JoyState."""
    pytest.importorskip("pygame")
    from racecar_sim.control.joy_device import Gamepad, start_sdl

    pg = start_sdl()

    class Pad:  # an opened pygame Joystick: 6 axes, 11 buttons (button 7 held at opening), 1 hat
        def get_instance_id(self):
            return 4242

        def get_name(self):
            return "Test Pad"

        def get_numaxes(self):
            return 6

        def get_numbuttons(self):
            return 11

        def get_numhats(self):
            return 1

        def get_button(self, i):
            return i == 7

        def get_axis(self, i):
            return -1.0 if i in (2, 5) else 0.0  # triggers rest at -1

    pg.event.clear()
    gamepad = Gamepad(Pad(), pygame=pg)
    (opened,) = gamepad.read()
    assert opened == ("opened", "Test Pad", 6, 11, 1, [7])
    state = JoyState(0.01, *opened[2:])
    scale = 32768 if getattr(pg, "IS_CE", False) else 32767  # how pygame turns the driver's whole number to a float
    for kind, fields in (
        (pg.JOYAXISMOTION, {"axis": 1, "value": -32768 / scale}),  # left stick full up
        (pg.JOYAXISMOTION, {"axis": 0, "value": -16384 / scale}),  # left stick half left
        (pg.JOYAXISMOTION, {"axis": 3, "value": 300 / scale}),  # right stick x inside the dead zone
        (pg.JOYAXISMOTION, {"axis": 2, "value": -32768 / scale}),  # a trigger at rest: joy_node reads 0 until it moves
        (pg.JOYAXISMOTION, {"axis": 5, "value": -32768 / scale}),
        (pg.JOYAXISMOTION, {"axis": 5, "value": 32767 / scale}),  # the other trigger pulled all the way
        (pg.JOYBUTTONDOWN, {"button": 4}),
        (pg.JOYBUTTONDOWN, {"button": 0}),
        (pg.JOYBUTTONUP, {"button": 0}),
        (pg.JOYHATMOTION, {"hat": 0, "value": (-1, 1)}),  # d-pad up-left
    ):
        pg.event.post(pg.event.Event(kind, instance_id=4242, joy=0, **fields))
    pg.event.post(pg.event.Event(pg.JOYBUTTONDOWN, instance_id=9, joy=1, button=2))  # another device's
    events = gamepad.read()
    assert [e for e in events if e[0] == "axis" and e[1] == 2] == []  # the trigger never moved
    assert ("button", 2, True) not in events
    for event in events:
        state.apply(event)
    msg = state.message(1_500_000_000)
    assert isinstance(msg, Joy) and msg.header.stamp.sec == 1 and msg.header.frame_id == ""
    assert msg.axes.dtype == np.float32 and msg.buttons.dtype == np.int32

    def joy_node(raw: int) -> float:  # joy_node.cpp's arithmetic, deadzone 0.01
        unscaled = 32767.0 * 0.01
        moved = raw - unscaled if raw > unscaled else raw + unscaled if raw < -unscaled else 0.0
        return moved * (-1.0 / (1.0 - 0.01) / 32767.0)

    expected_axes = [joy_node(-16384), joy_node(-32768), 0.0, 0.0, 0.0, joy_node(32767)] + [1.0, 1.0]  # hat: x, y
    np.testing.assert_allclose(msg.axes, np.float32(expected_axes), rtol=1e-7)
    assert msg.axes[1] > 1.0 and msg.axes[5] == -1.0  # -32768 is a hair past +1 in joy_node too
    assert msg.buttons.tolist() == [0, 0, 0, 0, 1, 0, 0, 1, 0, 0, 0]
    pg.event.post(pg.event.Event(pg.JOYDEVICEREMOVED, instance_id=4242))
    assert gamepad.read() == [("closed",)] and not gamepad.connected
    gamepad.close()


def test_a_gamepad_publishes_joy_at_the_autorepeat_rate_and_stops_when_unplugged(pads):
    from racecar_sim.control.joy_device import open_gamepad

    pads.attach()
    with pytest.raises(ConfigError, match=r"^no gamepad matches 'F710' \(found 0: Virtual Controller\)$"):
        open_gamepad("F710")
    gamepad = open_gamepad("virtual")  # a part of the name
    config, _ = load_joy_teleop()
    sim = Simulator(world="empty", lidar=False, camera=False)
    joy = sim.add_node(lambda ctx: JoyNode(ctx.bus, ctx.timers, ctx.now, gamepad, config))
    received: list[tuple[float, Joy]] = []
    sim.subscribe(JOY, lambda m: received.append((sim.time, m)))
    sim.run_until(1.0)
    times = [t for t, _ in received]
    assert times[0] == pytest.approx(0.01) and np.allclose(np.diff(times), 0.05)  # 20 Hz from the first look
    assert received[0][1].axes.tolist() == [0.0] * 8 and received[0][1].buttons.tolist() == [0] * 11
    pads.set(gamepad.instance_id, axes={1: -16384, 3: 8192}, buttons={4: 1}, hat=2)
    sim.run_until(1.02)
    ((t, msg),) = [(t, m) for t, m in received if t > 1.0]
    assert t == pytest.approx(1.01)  # at once (the next look), not at the next repeat
    np.testing.assert_allclose(  # stick up: +; stick right: -; hat right: -
        msg.axes[[1, 3, 6, 7]], np.float32([(16384 / 32767 - 0.01) / 0.99, -(8192 / 32767 - 0.01) / 0.99, -1, 0])
    )
    assert msg.buttons[4] == 1 and msg.buttons.sum() == 1
    pads.detach(pads.attached[0])
    sim.run_until(2.0)
    assert not joy.connected and max(t for t, _ in received) < 1.1  # nothing while it is gone
    index = pads.attach()  # plugged in again: opened again, its state afresh
    sim.run_until(2.5)
    assert joy.connected and len([t for t, _ in received if t > 2.0]) >= 9
    assert received[-1][1].buttons.sum() == 0 and index == 0
    sim.close()


def test_two_gamepads_each_read_their_own_events(pads):
    """A fleet's cars may each have a joy_node: SDL's one event queue is shared out by device."""
    from racecar_sim.control.joy_device import open_gamepad

    pads.attach(), pads.attach()
    first, second = open_gamepad("0"), open_gamepad("/dev/input/js1")
    assert first.instance_id != second.instance_id
    first.read(), second.read()  # their "opened"
    pads.set(first.instance_id, buttons={4: 1})
    pads.set(second.instance_id, buttons={5: 1})
    assert first.read() == [("button", 4, True)] and second.read() == [("button", 5, True)]
    second.close()
    pads.set(first.instance_id, buttons={4: 0})
    assert first.read() == [("button", 4, False)]
    first.close()


# --- joy_teleop.py --------------------------------------------------------------------------------------------
def joy(axes: dict[int, float], buttons: tuple[int, ...] = ()) -> Joy:
    values = np.zeros(8, np.float32)
    for i, v in axes.items():
        values[i] = v
    pressed = np.zeros(11, np.int32)
    pressed[list(buttons)] = 1
    return Joy(Header(), values, pressed)


def joystick_sim(commands=None, **kwargs) -> tuple[Simulator, JoyTeleop, dict[str, list]]:
    sim = Simulator(world="empty", lidar=False, camera=False, **kwargs)
    commands = commands if commands is not None else load_joy_teleop()[1]
    teleop = sim.add_node(lambda ctx: JoyTeleop(ctx.bus, commands))
    log: dict[str, list] = {"odom": [], "joints": [], "output": [], "teleop": []}
    sim.subscribe("/vesc/odom", log["odom"].append)
    sim.subscribe("/racecar/joint_states", log["joints"].append)
    sim.subscribe(OUTPUT, lambda m: log["output"].append((sim.time, m.drive)))
    sim.subscribe(TELEOP_INPUT, lambda m: log["teleop"].append((sim.time, m.drive)))
    return sim, teleop, log


def at_20_hz(sim: Simulator, message, start: float, stop: float) -> None:
    """joy_node's autorepeat: `message(t)` published at 20 Hz from `start` to before `stop`."""

    def tick(now_ns: int) -> None:
        if start <= now_ns * 1e-9 < stop - 1e-9:
            sim.publish(JOY, message(now_ns * 1e-9))

    sim.scheduler.every(20.0, tick, "joy_node (test)")


def heading_speed(odom) -> tuple[float, float]:
    q, v = odom.pose.pose.orientation, odom.twist.twist
    yaw = math.atan2(2 * (q.w * q.z + q.x * q.y), 1 - 2 * (q.y * q.y + q.z * q.z))
    return v.linear.x * math.cos(yaw) + v.linear.y * math.sin(yaw), v.angular.z


@pytest.mark.parametrize(("speed_axis", "steer_axis"), [(0.5, 0.5), (0.25, -1.0), (-0.3, 0.0)])
def test_the_deadman_drives_at_2_x_axis_1_and_steers_034_x_axis_3(speed_axis, steer_axis):
    sim, teleop, log = joystick_sim()
    at_20_hz(sim, lambda t: joy({SPEED_AXIS: speed_axis, STEER_AXIS: steer_axis}, (DEADMAN,)), 0.0, 10.0)
    sim.run_until(3.0)
    speed, steering = 2.0 * speed_axis, 0.34 * steer_axis
    assert teleop.command == "human_control"
    commands = [(d.speed, d.steering_angle) for _, d in log["teleop"]]
    assert len(commands) == 60 and all(c == pytest.approx((speed, steering), rel=1e-6) for c in commands)
    assert sim.car.chain.in_control() == "Teleoperation"
    v, yaw_rate = heading_speed(log["odom"][-1])
    assert v == pytest.approx(speed, abs=0.01)  # the seed profile: the commanded speed is the ground speed
    wheelbase = VehicleGeometry.from_robot(sim.car.robot).wheelbase  # from the URDF's hinge and axle joints
    assert yaw_rate == pytest.approx(v * math.tan(steering) / wheelbase, rel=0.01, abs=1e-3)  # the bicycle model
    joints = log["joints"][-1]
    left, right = (joints.position[list(joints.name).index(f"{s}_steering_hinge_joint")] for s in ("left", "right"))
    if steering == 0.0:
        assert abs(left) < 1e-3 and abs(right) < 1e-3
    else:  # Ackermann's hinges: the mean of their cotangents is the cotangent of the commanded angle
        assert (1 / math.tan(left) + 1 / math.tan(right)) / 2 == pytest.approx(1 / math.tan(steering), rel=2e-3)
    sim.close()


def test_releasing_the_deadman_stops_the_car_at_once_with_the_shipped_yaml():
    """The racecar-v2 joy_teleop.yaml's default command: no bumper held, a zero command on the teleop input."""
    sim, teleop, log = joystick_sim()
    at_20_hz(sim, lambda t: joy({SPEED_AXIS: 0.5}, (DEADMAN,) if t < 2.0 else ()), 0.0, 10.0)
    sim.run_until(4.0)
    assert teleop.command == "default"
    after = [(t, d.speed) for t, d in log["output"] if t >= 2.0]
    assert after[0] == (pytest.approx(2.0), 0.0) and all(s == 0.0 for _, s in after)
    assert sim.car.chain.in_control() == "Teleoperation"  # the zero command holds the car: safety first
    assert abs(heading_speed(log["odom"][-1])[0]) < 0.02
    sim.close()


def test_without_a_default_command_a_released_deadman_lets_the_mux_time_out(tmp_path):
    (tmp_path / "joy_teleop.yaml").write_text(NO_DEFAULT_YAML)
    config, commands = load_joy_teleop(tmp_path / "joy_teleop.yaml")
    assert config == JoyNodeConfig(0.01, 20.0, 0.01)
    sim, teleop, log = joystick_sim(commands)
    at_20_hz(sim, lambda t: joy({SPEED_AXIS: 1.0, STEER_AXIS: 0.5}, (DEADMAN,) if t < 2.0 else ()), 0.0, 10.0)
    sim.run_until(1.9)
    assert heading_speed(log["odom"][-1])[0] == pytest.approx(1.5, abs=0.02)
    sim.run_until(4.0)
    last = max(t for t, _ in log["teleop"])
    assert last == pytest.approx(1.95) and teleop.command is None  # nothing published once released
    stop = min(t for t, d in log["output"] if t > last and d.speed == 0.0)
    assert stop <= last + MUX_TIMEOUT + DEFAULT_PERIOD + 1e-9  # the timeout, then the next 6 Hz zero command
    assert all(d.speed == 1.5 for t, d in log["output"] if t < stop and t > 1.0)
    assert abs(heading_speed(log["odom"][-1])[0]) < 0.02
    sim.close()


def test_the_right_bumper_hands_the_car_to_navigation():
    """autonomous_control: an Int8 to /dev/null, so the teleop input times out and navigation drives."""
    sim, teleop, log = joystick_sim()
    nulls = []
    sim.subscribe("/dev/null", nulls.append)

    def navigation(now_ns: int) -> None:
        sim.publish(NAVIGATION, AckermannDriveStamped(Header.at(now_ns), AckermannDrive(speed=0.8)))

    sim.scheduler.every(20.0, navigation, "driver")
    at_20_hz(sim, lambda t: joy({SPEED_AXIS: 1.0}, (5,) if t >= 1.0 else ()), 0.0, 10.0)
    sim.run_until(0.9)
    assert sim.car.chain.in_control() == "Teleoperation" and abs(heading_speed(log["odom"][-1])[0]) < 0.02
    sim.run_until(3.0)
    assert teleop.command == "autonomous_control" and len(nulls) == 41 and nulls[0].data == 0  # 1.00 ... 3.00 s
    assert sim.car.chain.in_control() == "Navigation"
    assert heading_speed(log["odom"][-1])[0] == pytest.approx(0.8, abs=0.02)
    sim.close()


def test_buttons_held_with_the_deadman_run_the_default_command():
    """Only the exact buttons of a command run it (joy_teleop.py's match_command)."""
    _, commands = load_joy_teleop()
    sim, teleop, log = joystick_sim(commands)
    at_20_hz(sim, lambda t: joy({SPEED_AXIS: 1.0}, (0, DEADMAN)), 0.0, 10.0)
    sim.run_until(1.0)
    assert teleop.command == "default" and all(d.speed == 0.0 for _, d in log["teleop"])
    sim.close()


def test_another_type_on_vesc_joy_is_named_once_and_dropped(caplog):
    sim, teleop, log = joystick_sim()
    with caplog.at_level(logging.WARNING, "racecar_sim.joy"):
        for _ in range(3):
            sim.publish(JOY, AckermannDriveStamped(Header(), AckermannDrive(speed=1.0)))
    assert teleop.received == 0 and log["teleop"] == []
    assert [r.getMessage() for r in caplog.records] == [
        "/vesc/joy: ignored a AckermannDriveStamped message (the topic takes sensor_msgs/Joy)"
    ]
    sim.close()


@pytest.mark.parametrize(
    ("edit", "message"),
    [
        ("target: drive.speed, scale: 2.0", "teleop: human_control: 'AckermannDrive' object has no attribute 'sped'"),
        ("deadman_buttons: [4]", "teleop: human_control: deadman_buttons: expected a whole number >= 0, got 'LB'"),
        ("type: topic\n    message_type: ackermann", "teleop: human_control: unknown type 'joystick'"),
        ("scale: 0.34", "teleop: human_control: axis_mappings: scale: expected a finite number, got 'wide'"),
    ],
)
def test_a_broken_joy_teleop_yaml_names_the_file_the_command_and_the_field(tmp_path, edit, message):
    text = (STAND_IN / "config/racecar-v2/joy_teleop.yaml").read_text()
    replacement = {
        "target: drive.speed, scale: 2.0": "target: drive.sped, scale: 2.0",
        "deadman_buttons: [4]": "deadman_buttons: [LB]",
        "type: topic\n    message_type: ackermann": "type: joystick\n    message_type: ackermann",
        "scale: 0.34": "scale: wide",
    }[edit]
    if edit.startswith("type:"):  # the human_control entry's type
        head, _, tail = text.partition("human_control:")
        text = head + "human_control:" + tail.replace("type: topic", "type: joystick", 1)
    else:
        assert edit in text
        text = text.replace(edit, replacement)
    path = tmp_path / "joy_teleop.yaml"
    path.write_text(text)
    with pytest.raises(ConfigError) as err:
        load_joy_teleop(path)
    assert str(err.value).startswith(f"{path}: {message}")


def test_actions_services_and_unknown_types_are_named_and_skipped(caplog):
    teleop = {
        "walk": {"type": "action", "action_name": "move_base"},
        "beep": {"type": "topic", "message_type": "std_msgs/Empty", "topic_name": "beep", "message_value": []},
        "stop": {
            "type": "topic",
            "message_type": "std_msgs/Int8",
            "topic_name": "/stop",
            "message_value": [{"target": "data", "value": 1}],
        },
    }
    with caplog.at_level(logging.WARNING, "racecar_sim.joy"):
        (stop,) = parse_commands(teleop, "/vesc/teleop")
    assert stop.name == "stop" and stop.buttons == () and not stop.is_default
    assert [r.getMessage() for r in caplog.records] == [
        "/vesc/teleop: walk: a action command is not run in the sim (only topic commands are)",
        "/vesc/teleop: beep: message type std_msgs/Empty is not one the sim has: command skipped",
    ]
    with pytest.raises(ConfigError, match=r"^/vesc/teleop: no commands"):
        parse_commands({}, "/vesc/teleop")


# --- racecar-sim teleop --joy ---------------------------------------------------------------------------------
def cli(*args: str, code: str = "") -> subprocess.CompletedProcess:
    program = f"{code}\nfrom racecar_sim.cli.main import main\nraise SystemExit(main({list(args)!r}))"
    return subprocess.run(
        [sys.executable, "-c", program],
        stdin=subprocess.DEVNULL,
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )


def test_teleop_joy_without_a_gamepad_is_one_line_and_exit_2():
    pytest.importorskip("pygame")
    result = cli("teleop", "--joy", "--no-camera")
    assert result.returncode == 2 and result.stdout == ""
    assert result.stderr == (
        "racecar-sim: error: teleop --joy: no gamepad found (SDL sees no joystick): plug one in, or check its "
        "permissions\n"
    )


def test_teleop_joy_without_pygame_says_what_to_install():
    result = cli("teleop", "--joy", "0", "--no-camera", code="import sys; sys.modules['pygame'] = None")
    assert result.returncode == 2 and result.stdout == ""
    assert result.stderr == (
        "racecar-sim: error: teleop --joy: reading a gamepad needs pygame-ce, which is not installed: "
        "pip install 'racecar-sim[joy]'\n"
    )


@contextlib.contextmanager
def terminal_stderr(monkeypatch):
    """sys.stderr on a pseudo-terminal (so the status line is drawn); yields a list that collects what it shows."""
    master, slave = os.openpty()
    fcntl.ioctl(slave, termios.TIOCSWINSZ, struct.pack("HHHH", 24, 300, 0, 0))  # wide: the line is not cut
    shown: list[str] = []

    def drain() -> None:
        with contextlib.suppress(OSError):
            while chunk := os.read(master, 65536):
                shown.append(chunk.decode(errors="replace"))

    reader = threading.Thread(target=drain, daemon=True)
    reader.start()
    stream = os.fdopen(slave, "w", buffering=1)
    monkeypatch.setattr(sys, "stderr", stream)
    try:
        yield shown
    finally:
        stream.close()
        reader.join(5)
        os.close(master)


def test_teleop_joy_drives_the_car_with_a_gamepad(pads, tmp_path, monkeypatch, capsys):
    """The CLI in this process, a virtual gamepad held at half speed ahead, steering a quarter left."""
    import racecar_sim.control.joy_device as joy_device
    from racecar_sim.cli.main import main

    pads.attach()
    opened = joy_device.open_gamepad

    def hold_the_sticks(selector=None, fallback=None):  # the user's hands, from the moment it opens
        gamepad = opened(selector, fallback)
        pads.set(gamepad.instance_id, axes={SPEED_AXIS: -16384, STEER_AXIS: -8192}, buttons={DEADMAN: 1})
        return gamepad

    monkeypatch.setattr(joy_device, "open_gamepad", hold_the_sticks)
    out = tmp_path / "joy.mcap"
    with terminal_stderr(monkeypatch) as shown:
        code = main(
            ["teleop", "--joy", "Virtual", "--duration", "3", "--no-camera", "--no-lidar", "--record", str(out)]
        )
    assert code == 0
    screen = "".join(shown)
    assert "Reading gamepad Virtual Controller and publishing sensor_msgs/Joy on /vesc/joy" in screen
    assert "hold buttons [4]: human_control, drive.speed = axis 1 x 2, drive.steering_angle = axis 3 x 0.34" in screen
    assert "| joy: human_control" in screen and "Teleoperation" in screen
    assert "--duration reached" in capsys.readouterr().out

    from rosbags.highlevel import AnyReader
    from rosbags.typesys import Stores, get_typestore

    with AnyReader([out], default_typestore=get_typestore(Stores.EMPTY)) as reader:
        wanted = [c for c in reader.connections if c.topic in (JOY, TELEOP_INPUT, "/vesc/odom")]
        data: dict[str, list] = {JOY: [], TELEOP_INPUT: [], "/vesc/odom": []}
        for connection, stamp, raw in reader.messages(connections=wanted):
            data[connection.topic].append((stamp * 1e-9, reader.deserialize(raw, connection.msgtype)))
    axis_speed, axis_steer = (16384 / 32767 - 0.01) / 0.99, (8192 / 32767 - 0.01) / 0.99  # stick up, stick left
    joys = data[JOY]
    assert len(joys) == pytest.approx(3.0 * 20, abs=2)
    assert joys[-1][1].axes[SPEED_AXIS] == pytest.approx(axis_speed) and joys[-1][1].buttons[DEADMAN] == 1
    *drives, final = [(t, m.drive.speed, m.drive.steering_angle) for t, m in data[TELEOP_INPUT]]
    assert len(drives) == len(joys) and [t for t, _, _ in drives] == [t for t, _ in joys]
    assert all(d[1:] == pytest.approx((2.0 * axis_speed, 0.34 * axis_steer)) for d in drives)
    assert final == (pytest.approx(3.0), 0.0, 0.0)  # teleop's zero command as it quits (the keyboard's, relayed)
    v, yaw_rate = heading_speed([m for t, m in data["/vesc/odom"] if t < 2.99][-1])  # before the final stop
    assert v == pytest.approx(2.0 * axis_speed, abs=0.02) and yaw_rate > 0.1  # ahead, turning left


def test_teleop_joy_reads_the_joy_teleop_yaml_of_a_racecar_package_on_the_package_path(pads, tmp_path, monkeypatch):
    import racecar_sim.control.joy_device as joy_device
    from racecar_sim.cli.main import main

    package = write_package_xml(tmp_path / "src" / "racecar", "racecar")
    (package / "config/racecar-v2").mkdir(parents=True)
    (package / "config/racecar-v2/joy_teleop.yaml").write_text(NO_DEFAULT_YAML)  # speed = 1.5 x axis 1
    monkeypatch.setenv("ROS_PACKAGE_PATH", "")  # restored after the test: --package-path goes in front of it
    pads.attach()
    opened = joy_device.open_gamepad

    def full_ahead(selector=None, fallback=None):
        gamepad = opened(selector, fallback)
        pads.set(gamepad.instance_id, axes={SPEED_AXIS: -32767}, buttons={DEADMAN: 1})
        return gamepad

    monkeypatch.setattr(joy_device, "open_gamepad", full_ahead)
    out = tmp_path / "joy.mcap"
    args = ["--joy", "--duration", "1", "--no-camera", "--no-lidar", "--record", str(out)]
    assert main(["teleop", *args, "--package-path", str(tmp_path / "src")]) == 0
    from rosbags.highlevel import AnyReader
    from rosbags.typesys import Stores, get_typestore

    with AnyReader([out], default_typestore=get_typestore(Stores.EMPTY)) as reader:
        wanted = [c for c in reader.connections if c.topic == TELEOP_INPUT]
        speeds = [reader.deserialize(raw, c.msgtype).drive.speed for c, _, raw in reader.messages(connections=wanted)]
    assert len(speeds) > 15 and set(speeds[:-1]) == {1.5} and speeds[-1] == 0.0  # the package's scale; the final stop


# --- racecar-sim launch ---------------------------------------------------------------------------------------
def test_the_racecar_packages_joy_teleop_launch_in_the_vesc_group_runs(tmp_path, caplog):
    """Without a gamepad: a warning, and /vesc/joy still takes sensor_msgs/Joy from the bus."""
    pytest.importorskip("pygame")
    (tmp_path / "joystick.launch").write_text(CAR_WITH_JOYSTICK)
    with caplog.at_level(logging.WARNING, "racecar_sim.launch"):
        setup = map_plan(load_launch(tmp_path / "joystick.launch"), camera=False, lidar=False)
        (joy_node,), (joy_teleop,) = setup.joy_nodes, setup.joy_teleops
        assert joy_node.topic == JOY and joy_node.config == JoyNodeConfig(0.01, 20.0, 0.01)  # from /vesc/joy_node
        assert joy_teleop.joy_topic == JOY and set(joy_teleop.topics.values()) == {TELEOP_INPUT, "/dev/null"}
        assert not setup.skipped
        with LaunchRun(setup) as run:
            assert run.joy_nodes == [] and len(run.joy_teleops) == 1
            warning = [r.getMessage() for r in caplog.records if "joy_node" in r.getMessage()]
            assert len(warning) == 1 and warning[0].endswith(
                "/vesc/joy_node (joy/joy_node): no gamepad found (SDL sees no joystick): plug one in, or check its "
                "permissions; /vesc/joy takes sensor_msgs/Joy from the bus"
            )
            sim = run.sim
            at_20_hz(sim, lambda t: joy({SPEED_AXIS: 0.5, STEER_AXIS: 0.0}, (DEADMAN,)), 0.0, 10.0)
            sim.run_until(2.0)
            assert sim.car.chain.in_control() == "Teleoperation"
            assert run.joy_teleops[0].command == "human_control"
            assert sim.car.state.base_pose()[0][0] > 1.0


def test_under_launch_joy_node_reads_the_gamepad(pads, tmp_path):
    pads.attach()
    (tmp_path / "joystick.launch").write_text(CAR_WITH_JOYSTICK)
    setup = map_plan(load_launch(tmp_path / "joystick.launch"), camera=False, lidar=False)
    with LaunchRun(setup) as run:
        (joy_node,) = run.joy_nodes
        assert joy_node.device_name is None and joy_node.topic == JOY
        pads.set(joy_node.device.instance_id, axes={SPEED_AXIS: -32767}, buttons={DEADMAN: 1})  # full ahead
        run.sim.run_until(2.0)
        assert joy_node.device_name == "Virtual Controller" and joy_node.published == pytest.approx(40, abs=1)
        assert run.joy_teleops[0].command == "human_control"
        v = run.sim.car.state.base_velocity()[0]
        assert math.hypot(v[0], v[1]) == pytest.approx(2.0, abs=0.05)


def test_a_users_own_racecar_package_and_joy_teleop_yaml_win(tmp_path, monkeypatch):
    """A racecar package on the package path (mux.launch, its YAMLs, joy_teleop.launch.xml as the original has
    them, and a joy_teleop.yaml without the default command) is what $(find racecar) finds, for launch and teleop."""
    package = write_package_xml(tmp_path / "src" / "racecar", "racecar")
    for relative in (
        "launch/mux.launch",
        "config/racecar-v2/high_level_mux.yaml",
        "config/racecar-v2/low_level_mux.yaml",
    ):
        (package / relative).parent.mkdir(parents=True, exist_ok=True)
        (package / relative).write_text((STAND_IN / relative).read_text())
    (package / "launch/includes/common").mkdir(parents=True)
    (package / "launch/includes/common/joy_teleop.launch.xml").write_text(JOY_TELEOP_LAUNCH)
    (package / "config/racecar-v2/joy_teleop.yaml").write_text(NO_DEFAULT_YAML)
    monkeypatch.setenv("ROS_PACKAGE_PATH", str(tmp_path / "src"))
    assert joy_teleop_yaml() == package / "config/racecar-v2/joy_teleop.yaml"  # teleop --joy reads this one
    (tmp_path / "joystick.launch").write_text(CAR_WITH_JOYSTICK)
    setup = map_plan(load_launch(tmp_path / "joystick.launch"), camera=False, lidar=False)
    (spec,) = setup.joy_teleops
    assert [c.name for c in spec.commands] == ["ackermann"]
    assert spec.commands[0].axis_mappings[0].scale == 1.5
    with LaunchRun(setup) as run:
        sim = run.sim
        at_20_hz(sim, lambda t: joy({SPEED_AXIS: 1.0}, (DEADMAN,) if t < 2.0 else ()), 0.0, 10.0)
        sim.run_until(1.9)
        assert sim.car.chain.in_control() == "Teleoperation"
        v = sim.car.state.base_velocity()[0]
        assert math.hypot(v[0], v[1]) == pytest.approx(1.5, abs=0.03)
        sim.run_until(2.0 + MUX_TIMEOUT + DEFAULT_PERIOD)
        assert sim.car.chain.in_control() != "Teleoperation"  # released: the input timed out


def test_joy_teleop_outside_the_vesc_group_is_named(tmp_path, caplog):
    """racecar_control's teleop.launch (gazebo_sim_joy.launch) includes it at the root: its commands go to
    /low_level/..., which no mux takes, in the original as here."""
    text = CAR_WITH_JOYSTICK.replace('<group ns="vesc">', "").replace("</group>", "")
    text = text.replace(
        '<include file="$(find racecar)/launch/mux.launch" />',
        '<include file="$(find racecar)/launch/mux.launch" ns="vesc"/>',
    )
    (tmp_path / "root.launch").write_text(text)
    with caplog.at_level(logging.WARNING, "racecar_sim.launch"):
        setup = map_plan(load_launch(tmp_path / "root.launch"), camera=False, lidar=False)
    assert setup.joy_teleops[0].joy_topic == "/joy"
    (warning,) = [r.getMessage() for r in caplog.records if "drives nothing" in r.getMessage()]
    assert (
        "/joy_teleop (racecar/joy_teleop.py) publishes its drive commands on /low_level/ackermann_cmd_mux/"
        "input/teleop, which no ackermann_cmd_mux of the launch takes" in warning
    )


def test_with_ros_vesc_joy_takes_sensor_msgs_joy_from_ros(tmp_path):
    """`launch --ros` without a gamepad: a ROS joy_node elsewhere (here `rostopic pub`) drives the car."""
    pytest.importorskip("pygame")
    from racecar_sim.bridges.ros1 import message_path, ros_available
    from racecar_sim.bridges.ros1.environment import ros_environment
    from racecar_sim.bridges.ros1.master import Master

    if not (Path("/usr/bin/roscore").exists() and ros_available()):
        pytest.skip("ROS 1 is not installed (apt-get install ros-core python3-rospy ...)")
    (tmp_path / "joystick.launch").write_text(CAR_WITH_JOYSTICK)
    setup = map_plan(load_launch(tmp_path / "joystick.launch"), ros=True, camera=False, lidar=False)
    core = Master(None, ros_environment(None, None), port=None)
    publisher = None
    try:
        with LaunchRun(setup, ros=True, master_uri=core.uri) as run:
            sim = run.sim
            publisher = subprocess.Popen(
                [
                    "rostopic",
                    "pub",
                    "-r",
                    "20",
                    JOY,
                    "sensor_msgs/Joy",
                    "{axes: [0, 0.4, 0, 0], buttons: [0, 0, 0, 0, 1]}",
                ],
                env=ros_environment(core.uri, message_path()),
                stdout=subprocess.DEVNULL,
            )
            end = time.monotonic() + 60
            while run.joy_teleops[0].received < 20 and time.monotonic() < end:
                sim.run_for(0.05)
                time.sleep(0.02)
            assert run.joy_teleops[0].command == "human_control"
            while sim.car.state.base_pose()[0][0] < 0.3 and time.monotonic() < end:
                sim.run_for(0.05)
                time.sleep(0.02)
            assert sim.car.chain.in_control() == "Teleoperation"
            v = sim.car.state.base_velocity()[0]
            assert math.hypot(v[0], v[1]) == pytest.approx(0.8, abs=0.05)  # 2.0 x axis 1
    finally:
        if publisher is not None:
            publisher.send_signal(signal.SIGINT)
            publisher.wait(10)
        core.close()


ORIGINALS = os.environ.get("RACECAR_GAZEBO_SRC"), os.environ.get("RACECAR_SRC")


@pytest.mark.skipif(not all(ORIGINALS), reason="RACECAR_GAZEBO_SRC and RACECAR_SRC name no checkouts of the originals")
def test_the_original_racecar_packages_joystick_files_run_unchanged(tmp_path, monkeypatch):
    """racecar's own joy_teleop.launch.xml and joy_teleop.yaml in <group ns="vesc"> (as in test_launch_original.py)."""
    monkeypatch.setenv("ROS_PACKAGE_PATH", os.pathsep.join(ORIGINALS))
    (tmp_path / "joystick.launch").write_text(CAR_WITH_JOYSTICK)
    setup = map_plan(load_launch(tmp_path / "joystick.launch"), camera=False, lidar=False)
    (spec,) = setup.joy_teleops
    assert Path(ORIGINALS[1]) in joy_teleop_yaml().parents
    assert {c.name for c in spec.commands} == {"default", "human_control", "autonomous_control"}
    with LaunchRun(setup) as run:
        sim = run.sim
        at_20_hz(sim, lambda t: joy({SPEED_AXIS: 0.5, STEER_AXIS: 0.0}, (DEADMAN,)), 0.0, 10.0)
        sim.run_until(2.0)
        assert run.joy_teleops[0].command == "human_control" and sim.car.chain.in_control() == "Teleoperation"
        v = sim.car.state.base_velocity()[0]
        assert math.hypot(v[0], v[1]) == pytest.approx(1.0, abs=0.03)
