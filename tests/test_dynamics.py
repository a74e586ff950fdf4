"""The car at racing speed against vehicle dynamics: the understeer gradient of the single-track model with the same
tyres, and a sine steer against the single-track equations (F1TENTH's / CommonRoad's published form, written here)
integrated with the car's own mass, yaw inertia, lf, lr and CG height."""

from __future__ import annotations

import math

import numpy as np
import pytest

from racecar_sim import Simulator
from racecar_sim.description import VehicleGeometry, load_robot
from racecar_sim.description.vehicle_params import VehicleParams, load_vehicle
from racecar_sim.msgs import AckermannDriveStamped
from racecar_sim.physics.actuation import STEER_KP, STEER_KV

G = 9.81
L = VehicleGeometry.from_robot(load_robot()).wheelbase
NAVIGATION = "/vesc/ackermann_cmd_mux/input/navigation"


def drive(vehicle: str, speed: float, steer, duration: float, rate: float = 100.0):
    """Drive with a command (speed, steer(t)) at 50 Hz; sample (t, forward speed, yaw rate) of base_link at `rate`.
    Returns the samples and the simulator (closed)."""
    sim = Simulator(world="empty", camera=False, lidar=False, vehicle=vehicle)
    samples: list[tuple[float, float, float]] = []

    def command(now: int) -> None:
        msg = AckermannDriveStamped()
        msg.drive.speed, msg.drive.steering_angle = speed, steer(now * 1e-9)
        sim.bus.publish(NAVIGATION, msg)

    def sample(now: int) -> None:
        linear, angular = sim.car.state.base_velocity(local=True)
        samples.append((now * 1e-9, float(linear[0]), float(angular[2])))

    sim.scheduler.every(50.0, command, "driver")
    sim.scheduler.every(rate, sample, "probe")
    sim.run_until(duration)
    sim.close()
    return np.array(samples)


def steady_turn(vehicle: str, speed: float, steer: float) -> tuple[float, float]:
    """(lateral acceleration in g, excess steer delta - atan(L kappa) in rad) of a steady constant-steer circle."""
    samples = drive(vehicle, speed, lambda t: steer, 8.0)
    last = samples[samples[:, 0] > 6.0]
    v, r = last[:, 1].mean(), last[:, 2].mean()
    return v * r / G, steer - math.atan(L * r / v)


@pytest.mark.parametrize(("vehicle", "expected", "tolerance"), [("f1tenth", None, 0.2), ("seed", 0.0, None)])
def test_understeer_gradient_in_the_linear_range(vehicle: str, expected: float | None, tolerance: float | None):
    params = load_vehicle(vehicle)
    points = [steady_turn(vehicle, speed, 0.1) for speed in (1.5, 2.5, 3.5)]
    a_y = np.array([p[0] for p in points])
    assert a_y.max() < 0.4 * params.mu  # the linear range
    gradient = np.polyfit(a_y, [p[1] for p in points], 1)[0]  # rad/g
    if expected is None:  # the single-track value of the same tyres: (1/mu)(1/C_Sf - 1/C_Sr) = 0.027 rad/g
        assert gradient == pytest.approx(params.understeer_gradient, rel=tolerance)
    else:
        assert abs(gradient) < 0.003  # no slip below the limit: the kinematic radius


def test_understeer_gradient_of_a_pacejka_file(tmp_path):
    # ForzaETH's NUC2 fit; in the linear range the magic formula's cornering stiffness is B C D per rad (normalised by
    # the load), so the single-track gradient is 1/(B C D)_front - 1/(B C D)_rear = 0.094 rad/g
    path = tmp_path / "nuc2.yaml"
    path.write_text("C_Pf: [4.80, 2.16, 0.650, 0.373]\nC_Pr: [20.0, 1.5, 0.618, 0.0]\n")
    expected = 1 / (4.80 * 2.16 * 0.650) - 1 / (20.0 * 1.5 * 0.618)
    points = [steady_turn(str(path), speed, 0.1) for speed in (1.0, 1.5, 2.0, 2.5)]
    a_y = np.array([p[0] for p in points])
    assert a_y.max() < 0.4 * 0.618
    gradient = np.polyfit(a_y, [p[1] for p in points], 1)[0]
    assert gradient == pytest.approx(expected, rel=0.2)


def body_of(vehicle: VehicleParams) -> dict[str, float]:
    """The car's own m, I_z (about its centre of mass), lf, lr and CG height, from the compiled model at rest."""
    sim = Simulator(world="empty", camera=False, lidar=False, vehicle=vehicle)
    sim.run_until(0.2)
    model, data = sim.model, sim.data
    root = model.body_rootid[sim.car.state.body_id]
    bodies = [b for b in range(model.nbody) if model.body_rootid[b] == root]
    mass = float(model.body_subtreemass[root])
    com = data.subtree_com[root].copy()
    inertia = 0.0
    for b in bodies:
        rotation = data.ximat[b].reshape(3, 3)
        inertia += (rotation @ np.diag(model.body_inertia[b]) @ rotation.T)[2, 2]
        inertia += model.body_mass[b] * float(np.sum((data.xipos[b, :2] - com[:2]) ** 2))
    base, _ = sim.car.state.base_pose()  # base_link: the ground point under the rear axle (the car faces +x)
    sim.close()
    lr = float(com[0] - base[0])
    return {"m": mass, "I": float(inertia), "lr": lr, "lf": L - lr, "h": float(com[2] - base[2])}


def single_track_yaw_rate(params: VehicleParams, body: dict[str, float], speed: float, steer, times: np.ndarray):
    """Yaw rate of the single-track model with load-normalised linear tyres (Althoff et al., CommonRoad vehicle
    models, the ST model as f1tenth_gym integrates it), at constant speed (no longitudinal acceleration, so no load
    transfer term), integrated with RK4 from straight-ahead driving."""
    mu, c_f, c_r = params.mu, params.C_Sf, params.C_Sr
    m, inertia, lf, lr = body["m"], body["I"], body["lf"], body["lr"]
    load_f, load_r = G * lr, G * lf  # g l_r and g l_f (u h = 0 at constant speed)

    def rates(t: float, state: np.ndarray) -> np.ndarray:
        yaw_rate, slip = state
        delta = steer(t)
        yaw_acceleration = (
            mu
            * m
            / (inertia * (lr + lf))
            * (
                lf * c_f * load_f * delta
                + (lr * c_r * load_r - lf * c_f * load_f) * slip
                - (lf * lf * c_f * load_f + lr * lr * c_r * load_r) * yaw_rate / speed
            )
        )
        slip_rate = (
            mu
            / (speed * (lr + lf))
            * (
                c_f * load_f * delta
                - (c_r * load_r + c_f * load_f) * slip
                + (c_r * load_r * lr - c_f * load_f * lf) * yaw_rate / speed
            )
            - yaw_rate
        )
        return np.array([yaw_acceleration, slip_rate])

    state, out, dt = np.zeros(2), [], 1e-4
    t = 0.0
    for target in times:
        while t < target - 1e-12:
            h = min(dt, target - t)
            k1 = rates(t, state)
            k2 = rates(t + h / 2, state + h / 2 * k1)
            k3 = rates(t + h / 2, state + h / 2 * k2)
            k4 = rates(t + h, state + h * k3)
            state, t = state + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4), t + h
        out.append(state[0])
    return np.array(out)


def test_a_sine_steer_follows_the_single_track_model():
    params = load_vehicle("f1tenth")
    speed, start, amplitude = 4.0, 3.0, 0.08

    def steer(t: float) -> float:
        return amplitude * math.sin(2 * math.pi * (t - start)) if t > start else 0.0

    samples = drive("f1tenth", speed, steer, start + 3.0)
    window = samples[samples[:, 0] > start]
    assert window[:, 1].mean() == pytest.approx(speed, rel=0.03)
    reference = single_track_yaw_rate(params, body_of(params), speed, lambda t: steer(t + start), window[:, 0] - start)
    rmse = float(np.sqrt(np.mean((window[:, 2] - reference) ** 2)))
    assert rmse <= 0.15 * np.abs(reference).max()


def hinge_and_speed(
    vehicle, speed: float, steer: float, start: float = 1.0, duration: float = 2.5, rolling: bool = False
) -> np.ndarray:
    """(t, left hinge, right hinge, forward speed, left hinge setpoint, right hinge setpoint) at 200 Hz with a command
    stepping from rest at `start` (rolling: driving straight at `speed` before, only the steering steps). The setpoint
    is the hinge actuator's activation where it has one (a rate-limited set), else its control."""
    sim = Simulator(world="empty", camera=False, lidar=False, vehicle=vehicle)
    model, data = sim.model, sim.data
    hinges = [model.jnt_qposadr[model.joint(f"{side}_steering_hinge_joint").id] for side in ("left", "right")]
    servos = [model.actuator(f"{side}_steering_hinge_position_controller").id for side in ("left", "right")]
    rows: list[list[float]] = []

    def setpoint(servo: int) -> float:
        adr = model.actuator_actadr[servo]
        return float(data.act[adr] if adr >= 0 else data.ctrl[servo])

    def command(now: int) -> None:
        msg = AckermannDriveStamped()
        on = now * 1e-9 > start
        msg.drive.speed, msg.drive.steering_angle = (speed, steer) if on else (speed if rolling else 0.0, 0.0)
        sim.bus.publish(NAVIGATION, msg)

    def sample(now: int) -> None:
        linear, _ = sim.car.state.base_velocity(local=True)
        rows.append([now * 1e-9, *data.qpos[hinges], float(linear[0]), *(setpoint(s) for s in servos)])

    sim.scheduler.every(50.0, command, "driver")
    sim.scheduler.every(200.0, sample, "probe")
    sim.run_until(duration)
    sim.close()
    return np.array(rows)


def test_the_steering_turns_no_faster_than_sv_max():
    sv_max = load_vehicle("f1tenth").sv_max
    rows = hinge_and_speed("f1tenth", 2.0, 0.4, start=2.0, duration=3.0, rolling=True)
    setpoint_rates = np.abs(np.diff(rows[:, 4:6], axis=0)) / np.diff(rows[:, 0])[:, None]
    assert setpoint_rates.max() <= sv_max * (1 + 1e-9)  # the command's rate limit
    # and the hinges follow it: a servo's lag behind a ramp, rate * kv / kp, and the tyres' torque aside
    assert np.abs(rows[:, 1:3] - rows[:, 4:6]).max() < sv_max * STEER_KV / STEER_KP + 0.02
    # and it does turn at the limit: the inner (left) hinge's ~0.5 rad in about 0.5 / 3.2 s, not the seed's 0.5 s lag
    reached = rows[np.argmax(rows[:, 1] > 0.9 * rows[-1, 1]), 0] - 2.02  # the first command after 2 s: 2.02 s
    assert reached < 0.9 * rows[-1, 1] / sv_max + 0.05


def test_the_car_accelerates_no_faster_than_a_max(tmp_path):
    path = tmp_path / "gentle.yaml"
    path.write_text("mu: 1.0489\nC_Sf: 4.718\nC_Sr: 5.4562\na_max: 2.0\n")  # F1TENTH's tyres, a gentle motor
    rows = hinge_and_speed(path, 4.0, 0.0, duration=3.0)
    t, v = rows[:, 0], rows[:, 3]
    window = 100  # 0.5 s: the launch from rest shakes the car for a moment on its tyres
    acceleration = (v[window:] - v[:-window]) / (t[window:] - t[:-window])
    assert acceleration.max() <= 1.1 * 2.0
    assert v[np.argmin(np.abs(t - 2.02))] == pytest.approx(2.0, rel=0.15)  # 1 s at 2 m/s^2
