"""ros_control's controller_manager (list/load/unload/switch, on the bus and in Python) and the controllers'
/racecar/<controller>/state topics.

Expectations come from ros_control (noetic controller_manager.cpp, effort_controllers), racecar_control.yaml and
the launch file's spawner, and from Newton's law for a car whose wheels get no effort.
"""

from __future__ import annotations

import logging
from pathlib import Path

import mujoco
import numpy as np
import pytest
import yaml
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

from racecar_sim import Car, Simulator, Spawn, msgs
from racecar_sim.bus.bus import ServiceError
from racecar_sim.description import package_path
from racecar_sim.drivers import ConstantCommand
from racecar_sim.msgs import idl
from racecar_sim.msgs.controller_manager_msgs import (
    ListControllersRequest,
    ListControllersResponse,
    ListControllerTypesRequest,
    LoadControllerRequest,
    SwitchControllerRequest,
    UnloadControllerRequest,
)

SHIPPED = package_path("racecar_control") / "config" / "racecar_control.yaml"
CM = "/racecar/controller_manager"
NAVIGATION = "/vesc/ackermann_cmd_mux/input/navigation"
REAR = ["left_rear_wheel_velocity_controller", "right_rear_wheel_velocity_controller"]
FRONT = ["left_front_wheel_velocity_controller", "right_front_wheel_velocity_controller"]
HINGES = ["left_steering_hinge_position_controller", "right_steering_hinge_position_controller"]
WHEELS = REAR + FRONT
# racecar_control.launch: spawner args, in this order
SPAWNED = [*WHEELS, *HINGES, "joint_state_controller"]
VELOCITY = "effort_controllers/JointVelocityController"
POSITION = "effort_controllers/JointPositionController"
JOINT_STATE = "joint_state_controller/JointStateController"
STRICT, BEST_EFFORT = 2, 1
RADIUS = 0.05  # wheel radius (m): the seed profile turns 1 m/s into 20 rad/s


@pytest.fixture
def sim():
    s = Simulator(world="empty", camera=False, lidar=False)
    yield s
    s.close()


def listed(sim: Simulator, prefix: str = "") -> dict[str, str]:
    """name -> state, through the list_controllers service."""
    response = sim.bus.call(f"{prefix}{CM}/list_controllers", ListControllersRequest())
    assert isinstance(response, ListControllersResponse)
    return {c.name: c.state for c in response.controller}


def switch(sim: Simulator, start=(), stop=(), strictness=STRICT, prefix: str = "") -> bool:
    request = SwitchControllerRequest(list(start), list(stop), strictness)
    return sim.bus.call(f"{prefix}{CM}/switch_controller", request).ok


def forward_speed(sim: Simulator) -> float:
    linear, _ = sim.car.state.base_velocity(local=True)
    return float(linear[0])


def actuator_forces(sim: Simulator, names: list[str], car: Car | None = None) -> np.ndarray:
    car = car or sim.car
    return np.array([sim.data.actuator_force[sim.model.actuator(car.names.mj(n)).id] for n in names])


# --- list_controllers -----------------------------------------------------------------------------------------
def test_list_controllers_at_start_is_what_the_spawner_leaves(sim):
    yaml_entries = yaml.safe_load(SHIPPED.read_text())["racecar"]
    response = sim.bus.call(f"{CM}/list_controllers", ListControllersRequest())
    assert [c.name for c in response.controller] == SPAWNED
    for c in response.controller:
        assert c.state == "running"
        assert c.type == yaml_entries[c.name]["type"]
        assert len(c.claimed_resources) == 1
        if c.type == JOINT_STATE:  # JointStateInterface claims no resources
            assert c.claimed_resources[0].hardware_interface == "hardware_interface::JointStateInterface"
            assert c.claimed_resources[0].resources == []
        else:
            assert c.claimed_resources[0].hardware_interface == "hardware_interface::EffortJointInterface"
            assert c.claimed_resources[0].resources == [yaml_entries[c.name]["joint"]]
    # the same through Python
    assert sim.car.controller_manager.list_controllers() == response.controller
    assert sim.car.controller_manager is sim.car.controller_manager
    assert {n: sim.car.controller_manager.controller_state(n) for n in SPAWNED} == dict.fromkeys(SPAWNED, "running")
    types = sim.bus.call(f"{CM}/list_controller_types", ListControllerTypesRequest())
    assert sorted(types.types) == sorted({VELOCITY, POSITION, JOINT_STATE})
    assert set(types.base_classes) == {"controller_interface::ControllerBase"}


def test_services_have_the_original_names(sim):
    for service in ("list_controllers", "switch_controller", "load_controller", "unload_controller"):
        assert f"{CM}/{service}" in sim.bus.services()
    with pytest.raises(ServiceError):
        sim.bus.call("/controller_manager/list_controllers", ListControllersRequest())


# --- stopping and starting while driving ---------------------------------------------------------------------
def test_stopping_the_rear_wheel_controllers_while_driving_coasts_them_and_the_car_slows(sim):
    """Against a 3 N drag on the chassis: four driven wheels hold ~1 m/s; with the rear controllers stopped the rear
    wheels get exactly 0 effort and only the front wheels (p = 0.5) push, so the car slows below what even slip-free
    front-wheel drive could hold, r (w_cmd - F r / sum p_front); started again, it accelerates back."""
    drag = 3.0
    sim.data.xfrc_applied[sim.car.state.body_id, 0] = -drag  # the car drives along +x
    ConstantCommand(sim.bus, sim.scheduler, 1.0, 0.0)
    sim.run_until(3.0)
    four_wheel = forward_speed(sim)
    assert four_wheel == pytest.approx(RADIUS * (20.0 - drag * RADIUS / 3.0), abs=0.01)  # sum p = 1 + 1 + 0.5 + 0.5
    assert np.all(actuator_forces(sim, REAR) > 0.01)

    assert switch(sim, stop=REAR)
    assert listed(sim) == {**dict.fromkeys(SPAWNED, "running"), **dict.fromkeys(REAR, "stopped")}
    sim.run_until(sim.time + sim.model.opt.timestep)  # the next physics step
    assert np.all(actuator_forces(sim, REAR) == 0.0)
    assert np.all(actuator_forces(sim, FRONT) != 0.0)
    speeds = []
    for _ in range(6):
        sim.run_until(sim.time + 0.5)
        assert np.all(actuator_forces(sim, REAR) == 0.0)  # the 20 Hz commands do not wake them
        speeds.append(forward_speed(sim))
    front_only_bound = RADIUS * (20.0 - drag * RADIUS / 1.0)
    assert speeds[0] < four_wheel - 0.05 and max(speeds) < front_only_bound - 0.02
    assert min(speeds) > 0.5  # the front wheels still drive: coasting against 3 N would stop it within 2 s

    assert switch(sim, start=REAR)
    assert listed(sim) == dict.fromkeys(SPAWNED, "running")
    sim.run_until(sim.time + 2.0)
    assert forward_speed(sim) == pytest.approx(four_wheel, abs=0.005)


def test_with_every_wheel_controller_stopped_the_car_decelerates_only_by_the_external_force(sim):
    """No effort on any wheel: a = F / (m + sum I_wheel / r^2), the wheels' inertia about their axles included."""
    drag = 4.0
    m, d = sim.model, sim.data
    ConstantCommand(sim.bus, sim.scheduler, 1.0, 0.0)
    sim.run_until(2.0)
    assert forward_speed(sim) == pytest.approx(1.0, abs=0.005)
    assert sim.car.controller_manager.stop(*WHEELS)
    d.xfrc_applied[sim.car.state.body_id, 0] = -drag
    inertia = np.zeros((m.nv, m.nv))
    mujoco.mj_fullM(m, d, inertia)
    dofs = [
        m.joint(j).dofadr[0]
        for j in (
            "left_rear_wheel_joint",
            "right_rear_wheel_joint",
            "left_front_wheel_joint",
            "right_front_wheel_joint",
        )
    ]
    mass = m.body_subtreemass[sim.car.state.body_id] + sum(inertia[i, i] for i in dofs) / RADIUS**2
    v0, t0 = forward_speed(sim), sim.time
    sim.run_until(t0 + 0.4)
    assert np.all(actuator_forces(sim, WHEELS) == 0.0)
    assert (v0 - forward_speed(sim)) / 0.4 == pytest.approx(drag / mass, rel=0.05)
    # without the drag it rolls on (the soft contacts take < 1 %/s): nothing brakes a wheel whose controller is stopped
    d.xfrc_applied[sim.car.state.body_id, 0] = 0.0
    v1 = forward_speed(sim)
    sim.run_until(sim.time + 2.0)
    assert forward_speed(sim) == pytest.approx(v1, rel=0.03)
    assert sim.car.controller_manager.start(*WHEELS)
    sim.run_until(sim.time + 1.0)
    assert forward_speed(sim) == pytest.approx(1.0, abs=0.005)


def test_starting_resets_the_command_as_effort_controllers_do(sim):
    """JointVelocityController::starting(): command 0; JointPositionController::starting(): command = the current
    position; the commands that arrive while they are stopped are not applied."""
    cm, state = sim.car.controller_manager, sim.car.state
    ConstantCommand(sim.bus, sim.scheduler, 1.0, 0.3)  # 20 Hz: keeps commanding the hinges and the wheels
    sim.run_until(0.5)
    assert cm.stop(HINGES[0], REAR[0])
    sim.run_until(1.5)
    assert np.all(actuator_forces(sim, [HINGES[0], REAR[0]]) == 0.0)
    hinge = sim.data.joint("left_steering_hinge_joint").qpos[0]
    held = sim.data.ctrl[state.actuator_ctrl(HINGES[0])[0]]  # servo_commands kept sending its angle
    assert abs(hinge - held) > 0.01  # the tyre forces turned the free hinge away from it
    assert cm.start(HINGES[0], REAR[0])
    assert sim.data.ctrl[state.actuator_ctrl(HINGES[0])[0]] == hinge
    assert sim.data.ctrl[state.actuator_ctrl(REAR[0])[0]] == 0.0
    sim.publish(f"/racecar/{HINGES[0]}/command", msgs.Float64(-0.2))
    assert sim.data.ctrl[state.actuator_ctrl(HINGES[0])[0]] == -0.2  # a running controller takes commands


def with_i_terms(tmp_path) -> Simulator:
    """A sim whose rear-left wheel and left hinge controllers have I-terms (the shipped YAML has none)."""
    data = yaml.safe_load(SHIPPED.read_text())
    data["racecar"][REAR[0]]["pid"].update(i=3.0, i_clamp=0.4)
    data["racecar"][HINGES[0]]["pid"].update(i=2.0, i_clamp=1.0)
    custom = tmp_path / "control.yaml"
    custom.write_text(yaml.safe_dump(data))
    return Simulator(world="empty", controllers=custom, camera=False, lidar=False)


def test_an_i_term_is_switched_off_with_its_controller_and_reset_at_start(tmp_path):
    sim = with_i_terms(tmp_path)
    ConstantCommand(sim.bus, sim.scheduler, 1.0, 0.3)
    sim.run_until(1.0)
    i_term = sim.model.actuator(f"{REAR[0]}/i_term").id
    assert sim.data.actuator_force[i_term] != 0.0
    assert sim.car.controller_manager.stop(REAR[0], HINGES[0])
    sim.run_until(1.5)
    assert sim.data.actuator_force[i_term] == 0.0
    assert np.all(actuator_forces(sim, [REAR[0], HINGES[0]]) == 0.0)
    assert sim.car.controller_manager.start(REAR[0], HINGES[0])
    hinge_act = sim.model.actuator(HINGES[0])
    assert sim.data.act[hinge_act.actadr[0]] == 0.0  # the PID's integral of the error starts over
    # the velocity I-term integrates the command: force = i (act - q) = 0 at the start
    q = sim.data.joint("left_rear_wheel_joint").qpos[0]
    assert sim.data.act[sim.model.actuator_actadr[i_term]] == q


# --- switch, load, unload semantics -----------------------------------------------------------------------------
def test_strict_switch_with_an_unknown_name_fails_and_changes_nothing(sim):
    before = listed(sim)
    gains = sim.model.actuator_biasprm.copy()
    assert not switch(sim, stop=[REAR[0], "no_such_controller"], strictness=STRICT)
    assert not switch(sim, start=["no_such_controller"], stop=[REAR[0]], strictness=STRICT)
    assert listed(sim) == before
    assert np.array_equal(sim.model.actuator_biasprm, gains)


def test_best_effort_switch_does_what_it_can(sim, caplog):
    assert switch(sim, stop=[REAR[0], "no_such_controller"], strictness=BEST_EFFORT)
    assert listed(sim)[REAR[0]] == "stopped"
    # stopping a stopped one and starting a running one: STRICT fails, BEST_EFFORT skips them
    assert not switch(sim, stop=[REAR[0]], strictness=STRICT)
    assert not switch(sim, start=[REAR[1]], strictness=STRICT)
    assert switch(sim, start=[REAR[0], "nope"], stop=[REAR[0]], strictness=BEST_EFFORT)
    assert listed(sim)[REAR[0]] == "running"
    with caplog.at_level(logging.WARNING, logger="racecar_sim.controller_manager"):
        assert switch(sim, stop=[REAR[1]], strictness=0)  # ros_control: defaults to BEST_EFFORT, with a warning
    assert "Defaulting to BEST_EFFORT" in caplog.text
    assert listed(sim)[REAR[1]] == "stopped"


def test_a_running_controller_in_both_lists_is_restarted(sim):
    sim.publish(f"/racecar/{REAR[0]}/command", msgs.Float64(12.0))
    ctrl = sim.car.state.actuator_ctrl(REAR[0])[0]
    assert sim.data.ctrl[ctrl] == 12.0
    assert switch(sim, start=[REAR[0]], stop=[REAR[0]], strictness=STRICT)
    assert listed(sim)[REAR[0]] == "running"
    assert sim.data.ctrl[ctrl] == 0.0  # starting() ran again
    # ros_control quirk: BEST_EFFORT skips the "already running" check but still calls starting() on it
    sim.publish(f"/racecar/{REAR[0]}/command", msgs.Float64(12.0))
    assert switch(sim, start=[REAR[0]], strictness=BEST_EFFORT)
    assert sim.data.ctrl[ctrl] == 0.0


def test_unload_and_load(sim):
    cm = sim.bus.call
    assert not cm(f"{CM}/unload_controller", UnloadControllerRequest(REAR[0])).ok  # still running
    assert not cm(f"{CM}/unload_controller", UnloadControllerRequest("no_such_controller")).ok
    assert switch(sim, stop=[REAR[0]])
    assert cm(f"{CM}/unload_controller", UnloadControllerRequest(REAR[0])).ok
    assert REAR[0] not in listed(sim)
    assert not cm(f"{CM}/unload_controller", UnloadControllerRequest(REAR[0])).ok
    assert not switch(sim, start=[REAR[0]], strictness=STRICT)  # not loaded
    assert not cm(f"{CM}/load_controller", LoadControllerRequest("no_such_controller")).ok  # not in the YAML
    assert cm(f"{CM}/load_controller", LoadControllerRequest(REAR[0])).ok
    assert not cm(f"{CM}/load_controller", LoadControllerRequest(REAR[0])).ok  # already loaded
    assert list(listed(sim).items())[-1] == (REAR[0], "initialized")  # appended; loaded, not started
    sim.run_until(0.1)
    assert actuator_forces(sim, [REAR[0]])[0] == 0.0
    assert switch(sim, start=[REAR[0]])
    assert listed(sim)[REAR[0]] == "running"
    ConstantCommand(sim.bus, sim.scheduler, 1.0, 0.0)
    sim.run_until(1.0)
    assert actuator_forces(sim, [REAR[0]])[0] != 0.0


def test_the_running_names_the_state_publisher_reads_follow_every_switch(sim):
    """The state publisher asks whether all of a car's controllers run with one look-up in a set the manager keeps:
    after every stop, unload, load, start and reset it holds exactly the controllers list_controllers says run."""
    cm = sim.car.controller_manager
    running = cm.state_publisher._running_names

    def check() -> None:
        assert running == {name for name, state in listed(sim).items() if state == "running"}

    check()
    assert running >= set(WHEELS)
    assert cm.stop(REAR[0], "joint_state_controller")
    check()
    assert cm.unload_controller(REAR[0])
    check()
    assert sim.bus.call(f"{CM}/load_controller", LoadControllerRequest(REAR[0])).ok
    check()
    assert switch(sim, start=[REAR[0]], stop=[REAR[1]])
    check()
    sim.reset()
    check()
    assert running >= set(WHEELS)


def test_stopping_the_joint_state_controller_stops_joint_states(sim):
    stamps = []
    sim.subscribe("/racecar/joint_states", lambda m: stamps.append(m.header.stamp.to_ns()))
    sim.run_until(1.0)
    assert len(stamps) == 50
    assert sim.car.controller_manager.stop("joint_state_controller")
    sim.run_until(2.0)
    assert len(stamps) == 50
    assert sim.car.controller_manager.start("joint_state_controller")
    sim.run_until(3.0)
    assert len(stamps) == 100


def test_two_controllers_on_one_joint_conflict(tmp_path, caplog):
    data = yaml.safe_load(SHIPPED.read_text())
    data["racecar"]["spare_controller"] = dict(data["racecar"][REAR[0]])
    custom = tmp_path / "control.yaml"
    custom.write_text(yaml.safe_dump(data, sort_keys=False))
    with caplog.at_level(logging.ERROR, logger="racecar_sim.controller_manager"):
        sim = Simulator(world="empty", controllers=custom, camera=False, lidar=False)
    assert "resource conflict" in caplog.text  # the spawner's STRICT switch fails, as in ros_control
    assert set(listed(sim).values()) == {"initialized"}
    everything = list(listed(sim))
    assert not switch(sim, start=everything, strictness=BEST_EFFORT)
    assert switch(sim, start=[n for n in everything if n != "spare_controller"])
    assert not switch(sim, start=["spare_controller"])
    assert switch(sim, start=["spare_controller"], stop=[REAR[0]])
    assert listed(sim)["spare_controller"] == "running" and listed(sim)[REAR[0]] == "stopped"


def test_reset_goes_back_to_the_spawner_state(sim):
    cm = sim.car.controller_manager
    assert cm.stop(*WHEELS, "joint_state_controller")
    assert cm.unload_controller(REAR[1])
    sim.run_until(0.5)
    sim.reset()
    assert listed(sim) == dict.fromkeys(SPAWNED, "running")
    assert list(listed(sim)) == SPAWNED
    ConstantCommand(sim.bus, sim.scheduler, 1.0, 0.0)
    joint_states = []
    sim.subscribe("/racecar/joint_states", joint_states.append)
    sim.run_until(2.0)
    assert forward_speed(sim) == pytest.approx(1.0, abs=0.005)
    assert len(joint_states) == 100


def test_a_stopped_controller_stays_without_effort_when_the_model_is_recompiled(sim):
    assert sim.car.controller_manager.stop(REAR[0])
    fresh = Simulator(world="empty", camera=False, lidar=False)  # the same car, compiled again: full gains
    sim.car.state.rebind(fresh.model, fresh.data)
    stopped, running = (fresh.model.actuator(n).id for n in REAR)
    assert np.all(fresh.model.actuator_biasprm[stopped] == 0.0)
    assert fresh.model.actuator_biasprm[running][2] == -1.0  # kv = p = 1
    assert sim.car.controller_manager.start(REAR[0])
    assert fresh.model.actuator_biasprm[stopped][2] == -1.0


# --- /racecar/<controller>/state ------------------------------------------------------------------------------------
def test_state_topics_at_100_hz_consistent_with_joint_states_and_the_yaml(sim):
    gains = {name: entry.get("pid", {}) for name, entry in yaml.safe_load(SHIPPED.read_text())["racecar"].items()}
    states: dict[str, list] = {name: [] for name in WHEELS + HINGES}
    for name, log in states.items():
        sim.subscribe(f"/racecar/{name}/state", log.append)
    joint_states = {}
    sim.subscribe("/racecar/joint_states", lambda m: joint_states.__setitem__(m.header.stamp.to_ns(), m))
    commands = {}
    for name in states:
        sim.subscribe(f"/racecar/{name}/command", lambda m, name=name: commands.__setitem__(name, m.data))
    ConstantCommand(sim.bus, sim.scheduler, 1.0, 0.2)
    sim.run_until(2.0)
    for name, log in states.items():
        assert [m.header.stamp.to_ns() for m in log] == [k * 10_000_000 for k in range(1, 201)]
        joint = sim.car.controllers.controllers[[c.name for c in sim.car.controllers.controllers].index(name)].joint
        for m in log:
            assert isinstance(m, msgs.JointControllerState)
            assert m.error == m.set_point - m.process_value
            assert (m.p, m.i, m.d, m.i_clamp) == tuple(float(gains[name].get(k, 0)) for k in ("p", "i", "d", "i_clamp"))
            assert m.time_step == sim.model.opt.timestep and m.antiwindup is False
            js = joint_states.get(m.header.stamp.to_ns())
            if js is not None:  # 50 Hz: every other state message
                k = js.name.index(joint)
                if name in HINGES:
                    assert (m.process_value, m.process_value_dot) == (js.position[k], js.velocity[k])
                    assert m.command == m.p * m.error - m.d * m.process_value_dot
                else:
                    assert m.process_value == js.velocity[k] and m.process_value_dot == 0.0
                    assert m.command == m.p * m.error
        assert log[-1].set_point == commands[name]  # the held command
    # like ros_control, `command` is the PID output before the +-10 N m effort limit
    first = next(m for m in states[REAR[0]] if m.set_point > 0.0 and m.header.stamp.to_ns() in joint_states)
    assert first.command > 10.0
    js = joint_states[first.header.stamp.to_ns()]
    assert abs(js.effort[js.name.index("left_rear_wheel_joint")]) == 10.0  # the applied effort is saturated
    # unsaturated, it is the effort the actuator applies in the next step
    message = states[HINGES[0]][-1]
    sim.run_until(2.0 + sim.model.opt.timestep)
    assert actuator_forces(sim, [HINGES[0]])[0] == pytest.approx(message.command, abs=1e-12)


def test_state_is_published_only_when_running_and_listened_to(sim):
    topic = f"/racecar/{REAR[0]}/state"
    sim.run_until(0.5)
    assert sim.bus.count(topic) == 0  # nobody listens
    log = []
    subscription = sim.subscribe(topic, log.append)
    sim.run_until(1.0)
    assert len(log) == 50
    assert sim.car.controller_manager.stop(REAR[0])
    sim.run_until(1.5)
    assert len(log) == 50  # a stopped controller is not updated
    assert sim.car.controller_manager.start(REAR[0])
    sim.run_until(2.0)
    assert len(log) == 100
    subscription.unsubscribe()  # nobody listens again: nothing more is made
    sim.run_until(2.5)
    assert len(log) == 100 and sim.bus.count(topic) == 100


def test_state_with_an_i_term_matches_the_actuator(tmp_path):
    sim = with_i_terms(tmp_path)
    last = {}
    for name in (REAR[0], HINGES[0]):
        sim.subscribe(f"/racecar/{name}/state", lambda m, name=name: last.__setitem__(name, m))
    ConstantCommand(sim.bus, sim.scheduler, 0.3, 0.3)
    sim.run_until(0.5)
    sim.run_until(0.5 + sim.model.opt.timestep)
    hinge = last[HINGES[0]]
    assert hinge.i == 2.0 and hinge.i_clamp == 1.0
    assert sim.data.actuator_force[sim.model.actuator(HINGES[0]).id] == pytest.approx(hinge.command, abs=1e-12)
    wheel = sim.model.actuator(REAR[0]).id, sim.model.actuator(f"{REAR[0]}/i_term").id
    assert sim.data.actuator_force[list(wheel)].sum() == pytest.approx(last[REAR[0]].command, abs=1e-12)


def test_state_message_cdr_matches_rosbags():
    store = get_typestore(Stores.ROS2_HUMBLE)
    for msgtype in (
        "control_msgs/msg/JointControllerState",
        "controller_manager_msgs/msg/HardwareInterfaceResources",
        "controller_manager_msgs/msg/ControllerState",
    ):
        store.register(get_types_from_msg(idl.get_spec(msgtype).text, msgtype))
    state = msgs.JointControllerState(
        msgs.Header.at(1_230_000_000), 20.0, 19.5, 0.0, 0.5, 0.0025, 0.5, 1.0, 0.0, 0.0, 0.0, False
    )
    reference = store.types["control_msgs/msg/JointControllerState"](
        header=store.types["std_msgs/msg/Header"](
            stamp=store.types["builtin_interfaces/msg/Time"](1, 230_000_000), frame_id=""
        ),
        set_point=20.0,
        process_value=19.5,
        process_value_dot=0.0,
        error=0.5,
        time_step=0.0025,
        command=0.5,
        p=1.0,
        i=0.0,
        d=0.0,
        i_clamp=0.0,
        antiwindup=False,
    )
    assert msgs.serialize(state) == store.serialize_cdr(reference, "control_msgs/msg/JointControllerState")
    cs = msgs.ControllerState("a", "running", VELOCITY, [msgs.HardwareInterfaceResources("hw", ["j1", "j2"])])
    assert msgs.deserialize(msgs.serialize(cs), "controller_manager_msgs/ControllerState") == cs
    assert msgs.message_class("control_msgs/JointControllerState") is msgs.JointControllerState


def test_recording_writes_the_state_topics_with_their_schema(sim, tmp_path: Path):
    from rosbags.highlevel import AnyReader

    path = tmp_path / "run.mcap"
    recorder = sim.record(path)
    sim.run_until(0.1)
    recorder.close()
    with AnyReader([path], default_typestore=get_typestore(Stores.EMPTY)) as reader:  # schemas from the file
        rows = [
            (c.topic, reader.deserialize(raw, c.msgtype))
            for c, _, raw in reader.messages()
            if c.topic == f"/racecar/{HINGES[0]}/state"
        ]
    assert len(rows) == 10
    assert rows[-1][1].p == 1.0 and rows[-1][1].d == 0.5 and rows[-1][1].time_step == sim.model.opt.timestep


# --- a fleet -----------------------------------------------------------------------------------------------------
def test_each_car_of_a_fleet_has_its_own_controller_manager():
    sim = Simulator(
        world="empty",
        cars=[
            Car("car1", camera=False, lidar=False),
            Car("car2", spawn=Spawn(0, 3, 0.05, 0), camera=False, lidar=False),
        ],
    )
    car1, car2 = sim.cars
    for car in (car1, car2):
        assert set(listed(sim, f"/{car.name}").values()) == {"running"}
        ConstantCommand(sim.bus, sim.scheduler, 1.0, 0.0, topic=car.topic(NAVIGATION))
    assert f"/car2{CM}/list_controllers" in sim.bus.services()
    assert f"{CM}/list_controllers" not in sim.bus.services()
    states = {car.name: [] for car in (car1, car2)}
    for car in (car1, car2):
        sim.subscribe(car.topic(f"/racecar/{REAR[0]}/state"), states[car.name].append)
    assert switch(sim, stop=WHEELS, prefix="/car2")
    assert set(listed(sim, "/car1").values()) == {"running"}
    assert {listed(sim, "/car2")[n] for n in WHEELS} == {"stopped"}
    sim.run_until(1.0)
    speed = {car.name: float(np.hypot(*car.state.base_velocity()[0][:2])) for car in (car1, car2)}
    assert speed["car1"] == pytest.approx(1.0, abs=0.02)
    assert speed["car2"] < 0.01  # its wheels get no effort
    assert np.all(actuator_forces(sim, WHEELS, car2) == 0.0)
    assert np.all(actuator_forces(sim, REAR, car1) != 0.0)
    assert len(states["car1"]) == 100 and states["car2"] == []
    assert switch(sim, start=WHEELS, prefix="/car2")
    sim.run_until(2.0)
    assert float(np.hypot(*car2.state.base_velocity()[0][:2])) == pytest.approx(1.0, abs=0.02)


def test_joint_states_and_controller_states_reach_a_listener_that_comes_and_goes_mid_run(sim):
    """Whether anyone listens is kept while the bus's listeners stay the same: a subscriber that comes mid-run gets
    joint states at 50 Hz and a controller's state at 100 Hz from its first tick, none after it left, and the topics
    count every tick throughout (tallied while unheard)."""
    topic = f"/racecar/{REAR[0]}/state"
    sim.run_until(0.5)
    joint_stamps: list[int] = []
    state_stamps: list[int] = []
    subs = [
        sim.bus.subscribe("/racecar/joint_states", lambda m: joint_stamps.append(m.header.stamp.to_ns())),
        sim.bus.subscribe(topic, lambda m: state_stamps.append(m.header.stamp.to_ns())),
    ]
    sim.run_until(1.0)
    for sub in subs:
        sub.unsubscribe()
    sim.run_until(1.5)
    ms = 1_000_000
    assert joint_stamps == [t * ms for t in range(520, 1001, 20)]
    assert state_stamps == [t * ms for t in range(510, 1001, 10)]
    assert sim.bus.count("/racecar/joint_states") == 75
