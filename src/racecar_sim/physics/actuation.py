"""A vehicle set's actuator limits in the model: the steering-rate limit (sv_min, sv_max) on the hinges' angle
setpoints and the acceleration limit (a_max) on the wheel-rate setpoints, as MuJoCo actuator dynamics (the `user`
dyntype, computed by the compiled callback in physics/tyre_callback.py): the setpoint moves towards the command at
no more than the limit, at every physics step, with no Python in the step.

A set with a steering-rate limit also steers as F1TENTH's single-track model does: the hinge follows its setpoint
closely (a stiff position servo, STEER_KP and STEER_KV), not through racecar_control.yaml's soft P = 1, D = 0.5 hinge
whose 0.5 s time constant is slower than the rate limit. A set without limits (`seed`) keeps the controllers as
they are, bit for bit.
"""

from __future__ import annotations

import mujoco

from racecar_sim.core.names import CarNames
from racecar_sim.description.urdf import Robot
from racecar_sim.description.vehicle import VehicleGeometry
from racecar_sim.description.vehicle_params import VehicleParams
from racecar_sim.physics.tyre_callback import install_actuator_dynamics

STEER_KP = 40.0  # N m/rad: the hinge's natural frequency ~50 Hz with its ~4e-4 kg m^2 about the kingpin
STEER_KV = 0.4  # N m s/rad: a little over critically damped; 10 ms behind a ramp


def limit_actuators(spec: mujoco.MjSpec, robot: Robot, names: CarNames, params: VehicleParams) -> None:
    """Rate-limit the car's hinge setpoints (sv_min..sv_max) and wheel-rate setpoints (a_max / wheel radius). Call
    after the controllers' actuators exist (and after open_differentials, whose carrier the wheel actuators drive)."""
    geometry = VehicleGeometry.from_robot(robot)
    hinges = {names.mj(w.hinge_joint) for w in geometry.wheels if w.hinge_joint}
    wheels = {names.mj(w.joint) for w in geometry.wheels} | {names.mj("drive_carrier_joint")}
    timestep = spec.option.timestep
    limited = False
    for actuator in spec.actuators:
        if actuator.trntype != mujoco.mjtTrn.mjTRN_JOINT or actuator.dyntype != mujoco.mjtDyn.mjDYN_NONE:
            continue
        if actuator.target in hinges and params.sv_max is not None:
            low = params.sv_min if params.sv_min is not None else -params.sv_max
            _servo(actuator, STEER_KP, STEER_KV, (low, params.sv_max, timestep))
            limited = True
        elif actuator.target in wheels and params.a_max is not None:
            kv = -actuator.biasprm[2]  # the velocity controller's P gain
            rate = params.a_max / geometry.wheel_radius
            _servo(actuator, 0.0, kv, (-rate, rate, timestep))
            limited = True
    if limited:
        install_actuator_dynamics()


def _servo(actuator: mujoco.MjsActuator, kp: float, kv: float, limits: tuple[float, float, float]) -> None:
    """A plain servo on its activation: force = gain act - kp q - kv qdot (kp = 0: a velocity servo, gain kv)."""
    actuator.dyntype = mujoco.mjtDyn.mjDYN_USER
    actuator.dynprm[:3] = list(limits)
    actuator.gaintype = mujoco.mjtGain.mjGAIN_FIXED
    actuator.gainprm[:3] = [kp if kp else kv, 0.0, 0.0]
    actuator.biastype = mujoco.mjtBias.mjBIAS_AFFINE
    actuator.biasprm[:3] = [0.0, -kp, -kv]
