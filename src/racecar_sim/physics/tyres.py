"""A vehicle set's tyre model at the wheel-ground contacts (the forces: physics/tyre_callback.py, compiled).

`prepare_tyres` puts into the MjSpec, for a car whose set has a tyre model: its wheels' collision geoms frictionless
(condim 1: MuJoCo keeps the normal contact, with its load transfer, kerbs and crashes; the ranking by friction gives
them the pair's priority), a touch sensor per wheel (its normal load) and the car's tyre table (a custom numeric).
`fill_tyre_table` writes the table once the model is compiled (body ids and sensor addresses exist only then), and
again after every recompile. The chassis stays MuJoCo's multibody.
"""

from __future__ import annotations

import mujoco
import numpy as np

from racecar_sim.core.names import CarNames
from racecar_sim.description.urdf import Robot
from racecar_sim.description.vehicle import VehicleGeometry
from racecar_sim.description.vehicle_params import VehicleParams
from racecar_sim.physics.tyre_callback import HEADER, LINEAR, MAGIC, PACEJKA, STRIDE, apply_ft_address, install

V_EPS_LONGITUDINAL = 1.0  # m/s: below it slip ratio is taken over this speed (the wheel's spin stays stable)
V_EPS_LATERAL = 0.3  # m/s: likewise for the slip angle


def table_name(names: CarNames) -> str:
    return names.mj("tyre_table")


def _touch_name(names: CarNames, link: str) -> str:
    return names.mj(f"{link}_tyre_load")


def prepare_tyres(spec: mujoco.MjSpec, robot: Robot, names: CarNames, params: VehicleParams) -> None:
    """The car's wheels ready for the tyre model of `params` (nothing for a set without one)."""
    if params.tyre_model == "none":
        return
    geometry = VehicleGeometry.from_robot(robot)
    for wheel in geometry.wheels:
        body = spec.body(names.mj(wheel.link))
        for geom in body.geoms:
            if geom.contype or geom.conaffinity:
                geom.condim = 1
                geom.friction = [0.0, 0.0, 0.0]
        # a site around the tyre: the touch sensor sums the normal forces of the contacts inside it
        site = body.add_site(
            name=_touch_name(names, wheel.link) + "_zone",
            type=mujoco.mjtGeom.mjGEOM_SPHERE,
            size=[1.5 * geometry.wheel_radius, 0, 0],
            pos=_centre_in_link(robot, wheel.link, wheel.centre),
            group=5,
        )
        spec.add_sensor(
            name=_touch_name(names, wheel.link),
            type=mujoco.mjtSensor.mjSENS_TOUCH,
            objtype=mujoco.mjtObj.mjOBJ_SITE,
            objname=site.name,
        )
    spec.add_numeric(name=table_name(names), data=[0.0] * (HEADER + STRIDE * len(geometry.wheels)))
    install()


CARRIER_INERTIA = 2e-3  # kg m^2 about the mean wheel axis: the motor and gears seen through the drive train


def open_differentials(spec: mujoco.MjSpec, robot: Robot, names: CarNames, params: VehicleParams) -> None:
    """With tyres, the wheels are driven through open differentials (the 1/10 car's centre, front and rear diffs):
    a carrier joint in the chassis turns at the mean of the four wheel rates (an equality constraint on a fixed
    tendon, so MuJoCo's solver carries it), and every wheel's velocity controller acts on the carrier. Each wheel
    then gets the same torque, and the mean wheel rate follows the mean of the commands; per-wheel rates each held
    to its kinematic value (the seed's law, exact without slip) would steer the car through its tyres and hide the
    understeer a tyre gives. (A tendon actuator would do the same, but MuJoCo's implicit step keeps only the diagonal
    of its damping across sibling wheels, and the rest made the 2.5 ms step unstable.) Call after the controllers'
    actuators exist; nothing without tyres."""
    if params.tyre_model == "none":
        return
    wheels = [names.mj(w.joint) for w in VehicleGeometry.from_robot(robot).wheels]
    chassis = spec.body(names.mj(robot.root))
    carrier_body = chassis.add_body(name=names.mj("drive_carrier"), mass=1e-6, inertia=[CARRIER_INERTIA] * 3)
    carrier = carrier_body.add_joint(name=names.mj("drive_carrier_joint"), type=mujoco.mjtJoint.mjJNT_HINGE)
    carrier.axis = [0.0, 1.0, 0.0]
    tendon = spec.add_tendon(name=names.mj("differentials"))
    for joint in wheels:
        tendon.wrap_joint(joint, 1.0 / len(wheels))
    tendon.wrap_joint(carrier.name, -1.0)
    differentials = spec.add_equality(
        name=names.mj("differentials"),
        type=mujoco.mjtEq.mjEQ_TENDON,
        name1=tendon.name,
        objtype=mujoco.mjtObj.mjOBJ_TENDON,
    )
    # stiffer than MuJoCo's default 0.02 s (the diffs wound up under hard acceleration and the rear wheels ran
    # backwards), softer than 2 steps (the car then weaved on a straight)
    differentials.solref = [4 * spec.option.timestep, 1.0]
    for actuator in spec.actuators:
        if actuator.trntype == mujoco.mjtTrn.mjTRN_JOINT and actuator.target in wheels:
            actuator.target = carrier.name
            if actuator.dyntype == mujoco.mjtDyn.mjDYN_NONE:
                # the P velocity servo as a plain velocity actuator (MuJoCo's pid gain type on the carrier joint
                # pushed against its command): force = kv ctrl - kv qdot
                kv = -actuator.biasprm[2]
                actuator.gaintype, actuator.biastype = mujoco.mjtGain.mjGAIN_FIXED, mujoco.mjtBias.mjBIAS_AFFINE
                actuator.gainprm[:3] = [kv, 0.0, 0.0]
                actuator.biasprm[:3] = [0.0, 0.0, -kv]
    # MuJoCo's sleeping (builder: static geoms placed once) does not take tendon equalities yet
    spec.option.enableflags &= ~int(mujoco.mjtEnableBit.mjENBL_SLEEP)


def _centre_in_link(robot: Robot, link: str, centre: tuple[float, float, float]) -> list[float]:
    """The tyre centre (base_link frame) in the wheel link's own frame."""
    from racecar_sim.core.transforms import quat_rotate
    from racecar_sim.description.kinematics import link_pose

    pos, quat = link_pose(robot, link)
    inverse = np.array([quat[0], -quat[1], -quat[2], -quat[3]])
    return [float(v) for v in quat_rotate(inverse, np.asarray(centre) - pos)]


def fill_tyre_table(model: mujoco.MjModel, robot: Robot, names: CarNames, params: VehicleParams) -> None:
    """Write the car's tyre table into the compiled model (bodies, sensors, tyre parameters per wheel)."""
    if params.tyre_model == "none":
        return
    geometry = VehicleGeometry.from_robot(robot)
    numeric = model.numeric(table_name(names))
    table = np.zeros(HEADER + STRIDE * len(geometry.wheels))
    table[0], table[1], table[2] = MAGIC, len(geometry.wheels), apply_ft_address()
    for i, wheel in enumerate(geometry.wheels):
        body = model.body(names.mj(wheel.link))
        sensor = model.sensor(_touch_name(names, wheel.link))
        axis = np.asarray(robot.joints[wheel.joint].axis, float)
        front = wheel.hinge_joint is not None
        row = table[HEADER + i * STRIDE : HEADER + (i + 1) * STRIDE]
        row[0], row[1], row[2], row[3] = body.id, model.body_rootid[body.id], sensor.adr[0], geometry.wheel_radius
        row[4:7] = axis / np.linalg.norm(axis)
        row[8] = params.mu
        if params.tyre_model == "pacejka":
            pacejka = params.pacejka_front if front else params.pacejka_rear
            assert pacejka is not None
            row[7] = PACEJKA
            row[10:14] = pacejka
        else:
            row[7] = LINEAR
            row[9] = params.C_Sf if front else params.C_Sr
        row[14], row[15] = V_EPS_LONGITUDINAL, V_EPS_LATERAL
        row[16:19] = _centre_in_link(robot, wheel.link, wheel.centre)
        spin_inertia = float(model.body_inertia[body.id].max())  # a wheel's largest principal axis is its spin axis
        row[19] = 0.5 * spin_inertia / (geometry.wheel_radius**2 * model.opt.timestep)
    model.numeric_data[numeric.adr[0] : numeric.adr[0] + len(table)] = table
