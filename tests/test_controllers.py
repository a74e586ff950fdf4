"""racecar_control.yaml becomes MuJoCo actuators that behave like ros_control's effort controllers."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml

from racecar_sim import Simulator
from racecar_sim.control.controllers import load_controller_config
from racecar_sim.core.errors import ConfigError
from racecar_sim.description import load_robot, package_path

SHIPPED = package_path("racecar_control") / "config" / "racecar_control.yaml"
HINGE = "left_steering_hinge_position_controller"


def test_shipped_config_has_the_original_gains():
    config = load_controller_config(SHIPPED, load_robot())
    gains = {c.name: (c.gains.p, c.gains.i, c.gains.d) for c in config.controllers}
    assert gains["left_rear_wheel_velocity_controller"] == (1.0, 0.0, 0.0)
    assert gains["right_front_wheel_velocity_controller"] == (0.5, 0.0, 0.0)
    assert gains[HINGE] == (1.0, 0.0, 0.5)
    assert config.joint_state_rate == 50


def hinge_error_under_torque(controllers: Path | None, torque: float) -> float:
    """The default zero command holds the hinge at 0 rad against a constant external torque: the error after 8 s."""
    sim = Simulator(controllers=controllers)
    dof = sim.model.jnt_dofadr[sim.model.joint("left_steering_hinge_joint").id]
    sim.data.qfrc_applied[dof] = -torque
    sim.run_until(8.0)
    return 0.0 - sim.data.joint("left_steering_hinge_joint").qpos[0]


def test_p_controller_leaves_error_torque_over_p_and_an_i_term_removes_it(tmp_path):
    torque = 0.05
    # effort = p e: a P-only position controller settles where p e balances the torque (p = 1)
    assert hinge_error_under_torque(None, torque) == pytest.approx(torque / 1.0, rel=0.05)
    data = yaml.safe_load(SHIPPED.read_text())
    data["racecar"][HINGE]["pid"].update(i=2.0, i_clamp=1.0)
    custom = tmp_path / "control.yaml"
    custom.write_text(yaml.safe_dump(data))
    assert abs(hinge_error_under_torque(custom, torque)) < 0.005


def test_velocity_i_term_is_clamped_by_i_clamp(tmp_path):
    data = yaml.safe_load(SHIPPED.read_text())
    data["racecar"]["left_rear_wheel_velocity_controller"]["pid"].update(i=3.0, i_clamp=0.4)
    custom = tmp_path / "control.yaml"
    custom.write_text(yaml.safe_dump(data))
    sim = Simulator(controllers=custom)
    act = sim.model.actuator("left_rear_wheel_velocity_controller/i_term")
    assert act.gainprm[0] == 3.0 and tuple(act.forcerange) == (-0.4, 0.4)
    sim.car.state.set_command("left_rear_wheel_velocity_controller", 5.0)
    sim.run_until(1.0)
    assert sim.data.actuator_force[act.id] <= 0.4 + 1e-9


def test_bad_controller_configs_name_file_and_field(tmp_path):
    robot = load_robot()
    bad = tmp_path / "bad.yaml"
    bad.write_text("racecar:\n  c:\n    type: effort_controllers/JointVelocityController\n    joint: nowhere_joint\n")
    with pytest.raises(ConfigError, match="bad.yaml: racecar/c: joint 'nowhere_joint'"):
        load_controller_config(bad, robot)
    bad.write_text("racecar:\n  c:\n    type: effort_controllers/JointEffortThing\n    joint: left_rear_wheel_joint\n")
    with pytest.raises(ConfigError, match="not supported"):
        load_controller_config(bad, robot)
    bad.write_text("racecar: [unclosed\n")
    with pytest.raises(ConfigError, match="bad.yaml"):
        load_controller_config(bad, robot)
