"""The tyre model at the wheel contacts (physics/tyres.py, physics/tyre_callback.py) against physics: a sliding car
decelerates at mu g, and the car's horizontal acceleration never leaves the friction circle; the callback reads
MuJoCo's structs where the bindings say the arrays are; `seed` keeps MuJoCo's own contact."""

from __future__ import annotations

import ctypes

import mujoco
import numpy as np
import pytest

from racecar_sim import Simulator
from racecar_sim.description.vehicle_params import load_vehicle
from racecar_sim.msgs import AckermannDriveStamped
from racecar_sim.physics import tyre_callback
from racecar_sim.physics.tyre_callback import layout

G = 9.81
NAVIGATION = "/vesc/ackermann_cmd_mux/input/navigation"


def word(address: int, offset: int) -> int:
    return int.from_bytes(ctypes.string_at(address + offset, 8), "little")


def test_the_callback_reads_the_fields_the_bindings_show():
    sim = Simulator(world="empty", camera=False, lidar=False, vehicle="f1tenth")
    offsets = layout()
    for name in ("xpos", "xmat", "cvel", "subtree_com", "sensordata", "qfrc_passive"):
        assert word(sim.data._address, offsets[name]) == getattr(sim.data, name).ctypes.data, name
    for name in ("numeric_adr", "numeric_data"):
        assert word(sim.model._address, offsets[name]) == getattr(sim.model, name).ctypes.data, name
    nnumeric = int.from_bytes(ctypes.string_at(sim.model._address + offsets["nnumeric"], 4), "little")
    assert nnumeric == sim.model.nnumeric >= 1
    sim.close()


def test_a_layout_the_probe_contradicts_is_an_error_naming_the_field(monkeypatch):
    """The offsets come from MuJoCo's struct declarations; a wrong size of one C type (mjtSize read as a 4-byte int
    shifts every later field) fails the check on the probe model, naming the first field it moved."""
    monkeypatch.setitem(tyre_callback._C_TYPES, "mjtSize", ctypes.c_int)
    layout.cache_clear()
    try:
        with pytest.raises(tyre_callback.LayoutError, match="field numeric_adr of mjModel"):
            layout()
    finally:
        layout.cache_clear()


def lateral_deceleration(vehicle: str) -> float:
    """m/s², mean over 0.15 s of the centre of mass of a car at rest on its wheels given 3 m/s sideways: every tyre
    slides."""
    sim = Simulator(world="empty", camera=False, lidar=False, vehicle=vehicle)
    sim.run_until(0.5)  # settled on its wheels, the tyres loaded
    deceleration = lateral_deceleration_of(sim)
    sim.close()
    return deceleration


def lateral_deceleration_of(sim: Simulator) -> float:
    """lateral_deceleration() of a car already at rest in `sim`."""
    body = sim.car.state.body_id
    dof, root = sim.model.jnt_dofadr[sim.model.body_jntadr[body]], sim.model.body_rootid[body]
    start_time = sim.time_ns * 1e-9
    sim.data.qvel[dof + 1] = 3.0

    def centre_of_mass_velocity() -> float:
        mujoco.mj_forward(sim.model, sim.data)
        mujoco.mj_subtreeVel(sim.model, sim.data)
        return float(sim.data.subtree_linvel[root, 1])

    sim.run_until(start_time + 0.05)  # past the first contact transient (the chassis rolls onto its outer wheels)
    start = centre_of_mass_velocity()
    sim.run_until(start_time + 0.2)
    return (start - centre_of_mass_velocity()) / 0.15


def test_a_car_sliding_sideways_decelerates_at_mu_g():
    # a saturated tyre gives mu F_z at every wheel, so the car decelerates at mu g (mu = 1.0489 for f1tenth)
    assert lateral_deceleration("f1tenth") == pytest.approx(load_vehicle("f1tenth").mu * G, rel=0.05)


def test_a_pacejka_tyre_sliding_gives_d_g(tmp_path):
    # the magic formula with C = 1, E = 0 is D sin(atan(B alpha)): at a slip angle near 90 degrees and B = 20, D
    path = tmp_path / "flat_top.yaml"
    path.write_text("C_Pf: [20.0, 1.0, 0.8, 0.0]\nC_Pr: [20.0, 1.0, 0.8, 0.0]\n")
    assert lateral_deceleration(str(path)) == pytest.approx(0.8 * G, rel=0.05)


def com_acceleration_peak(vehicle: str, steer: float, top: float = 6.0, ramp: float = 6.0) -> float:
    """Peak horizontal acceleration (g) of the car's centre of mass averaged over 0.5 s: a constant-steer circle with
    the speed command ramped up to past the top speed, then braking in the turn (command 0)."""
    sim = Simulator(world="empty", camera=False, lidar=False, vehicle=vehicle)
    root = sim.model.body_rootid[sim.car.state.body_id]
    com: list[np.ndarray] = []

    def command(now: int) -> None:
        t = now * 1e-9
        msg = AckermannDriveStamped()
        msg.drive.speed = 0.0 if t > ramp + 2.0 else min(top, top * t / ramp)
        msg.drive.steering_angle = steer
        sim.bus.publish(NAVIGATION, msg)

    rate = 200.0
    sim.scheduler.every(50.0, command, "circle then brake")
    sim.scheduler.every(rate, lambda now: com.append(sim.data.subtree_com[root, :2].copy()), "centre of mass")
    sim.run_until(ramp + 4.0)
    sim.close()
    acceleration = np.diff(np.array(com), 2, axis=0) * rate**2
    window = int(0.5 * rate)
    kernel = np.ones(window) / window
    mean = np.stack([np.convolve(acceleration[:, i], kernel, mode="valid") for i in range(2)], axis=1)
    return float(np.hypot(mean[:, 0], mean[:, 1]).max() / G)


@pytest.mark.parametrize("vehicle", ["seed", "f1tenth"])
@pytest.mark.parametrize("steer", [0.1, 0.3])
def test_the_car_stays_within_its_friction_circle(vehicle: str, steer: float):
    mu = load_vehicle(vehicle).mu  # seed: racecar.gazebo's mu 1
    peak = com_acceleration_peak(vehicle, steer)
    assert 0.5 < peak <= 1.05 * mu  # it did corner hard, and no harder than its tyres allow


def test_seed_has_no_tyre_table_and_keeps_its_coulomb_wheels():
    sim = Simulator(world="empty", camera=False, lidar=False)
    assert not any(sim.model.numeric(i).name.endswith("tyre_table") for i in range(sim.model.nnumeric))
    wheel = sim.model.body("left_rear_wheel")
    geoms = [g for g in range(sim.model.ngeom) if sim.model.geom_bodyid[g] == wheel.id and sim.model.geom_contype[g]]
    assert all(sim.model.geom_condim[g] == 3 and sim.model.geom_friction[g, 0] == 1.0 for g in geoms)
    sim.close()


def test_tyres_take_over_the_wheel_friction():
    sim = Simulator(world="empty", camera=False, lidar=False, vehicle="f1tenth")
    wheel = sim.model.body("left_rear_wheel")
    geoms = [g for g in range(sim.model.ngeom) if sim.model.geom_bodyid[g] == wheel.id and sim.model.geom_contype[g]]
    assert geoms and all(sim.model.geom_condim[g] == 1 for g in geoms)
    mujoco.mj_forward(sim.model, sim.data)
    sim.close()


def test_tyres_go_on_after_a_model_is_spawned_and_the_model_recompiled():
    from racecar_sim.msgs import Point, Pose, Quaternion
    from racecar_sim.msgs.gazebo_msgs import SpawnModelRequest

    box = """<sdf version="1.6"><model name="box"><static>true</static><link name="link">
      <collision name="c"><geometry><box><size>0.5 0.5 0.5</size></box></geometry></collision>
    </link></model></sdf>"""
    sim = Simulator(world="empty", camera=False, lidar=False, vehicle="f1tenth")
    sim.run_until(0.5)
    request = SpawnModelRequest("box1", box, "", Pose(Point(5.0, 5.0, 0.25), Quaternion(0.0, 0.0, 0.0, 1.0)))
    assert sim.bus.call("/gazebo/spawn_sdf_model", request).success
    sim.run_until(0.6)
    model, data = sim.model, sim.data
    loads = [
        data.sensordata[model.sensor_adr[i]] for i in range(model.nsensor) if model.sensor(i).name.endswith("_load")
    ]
    weight = model.body_subtreemass[model.body_rootid[sim.car.state.body_id]] * -model.opt.gravity[2]
    assert len(loads) == 4 and sum(loads) == pytest.approx(weight, rel=0.02)  # at rest on its four tyres
    assert lateral_deceleration_of(sim) == pytest.approx(load_vehicle("f1tenth").mu * G, rel=0.05)
    sim.close()
