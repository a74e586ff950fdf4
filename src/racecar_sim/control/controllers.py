"""ros_control joint controllers from racecar_control.yaml, realised as MuJoCo actuators.

The 1 kHz controller loop of gazebo_ros_control runs inside MuJoCo, not in Python:
  JointVelocityController   effort = p (w_cmd - w)           -> pid actuator, velocity setpoint input, kv = p
  JointPositionController   effort = p e - d w  (+ i int e)  -> pid actuator, position input, kp = p, kv = d, ki = i
and the URDF effort limit clamps the total on the joint (actfrcrange), as EffortJointSaturationHandle does.
An I-term on a velocity controller integrates (w_cmd - w), i.e. (integral of w_cmd) - q: a second actuator
with an integrator state on the command gives exactly i * (act - q), clamped to +-i_clamp.
The YAML itself is read by description/controllers.py.
"""

from __future__ import annotations

import mujoco

from racecar_sim.core.names import CarNames
from racecar_sim.description.controllers import (
    JOINT_STATE,
    POSITION,
    STEERING_HINGES,
    VELOCITY,
    ControllerConfig,
    Gains,
    JointController,
    load_controller_config,
)
from racecar_sim.description.urdf import Robot

__all__ = [
    "JOINT_STATE",
    "POSITION",
    "STEERING_HINGES",
    "VELOCITY",
    "ControllerConfig",
    "Gains",
    "JointController",
    "add_actuators",
    "load_controller_config",
]


def add_actuators(spec: mujoco.MjSpec, config: ControllerConfig, robot: Robot, names: CarNames = CarNames()) -> None:
    """Add one actuator per controller (two for a velocity controller with an I-term) to the spec."""
    for c in config.controllers:
        limit = robot.joints[c.joint].limit
        effort = limit.effort if limit and limit.effort > 0 else 0.0
        act = spec.add_actuator(name=names.mj(c.name), target=names.mj(c.joint), trntype=mujoco.mjtTrn.mjTRN_JOINT)
        if c.type == VELOCITY:
            act.set_to_pid(kp=0.0, kv=c.gains.p, ctrlspec=_input_mask("vel"))
            if c.gains.i:
                _add_velocity_integral(spec, c, names)
        else:
            act.set_to_pid(
                kp=c.gains.p,
                kv=c.gains.d,
                ki=c.gains.i,
                ctrlspec=_input_mask("pos"),
                imax=c.gains.i_clamp / c.gains.i if c.gains.i and c.gains.i_clamp else 0.0,
            )
        if effort:
            act.forcerange = [-effort, effort]
            act.forcelimited = mujoco.mjtLimited.mjLIMITED_TRUE


def _input_mask(*inputs: str) -> int:
    bits = {"pos": 1, "vel": 2, "ff": 4}
    return sum(bits[i] for i in inputs)


def _add_velocity_integral(spec: mujoco.MjSpec, c: JointController, names: CarNames) -> None:
    act = spec.add_actuator(
        name=names.mj(f"{c.name}/i_term"), target=names.mj(c.joint), trntype=mujoco.mjtTrn.mjTRN_JOINT
    )
    act.dyntype = mujoco.mjtDyn.mjDYN_INTEGRATOR  # act = integral of w_cmd
    act.gaintype = mujoco.mjtGain.mjGAIN_FIXED
    act.gainprm[0] = c.gains.i
    act.biastype = mujoco.mjtBias.mjBIAS_AFFINE
    act.biasprm[1] = -c.gains.i  # force = i (act - q)
    if c.gains.i_clamp:  # ros_control (kinetic) clamps the I-term, not the integral
        act.forcerange = [-c.gains.i_clamp, c.gains.i_clamp]
        act.forcelimited = mujoco.mjtLimited.mjLIMITED_TRUE
