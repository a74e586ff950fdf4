"""The car at racing speed per vehicle set: `python bench/bench_dynamics.py [--out DIR] [--quick]`.

For `seed` and `f1tenth`, in the empty world:
  circles    the issue's table: constant steer, each commanded speed for 8 s; speed and yaw rate are the means of the
             last 2 s of the ground truth (base_link), a_lat = v r, R / R0 with R0 = L / tan(steer)
  g-g        the horizontal acceleration of the centre of mass in the car's frame (0.1 s means) over constant-steer
             circles ramped past the top speed and then braking in the turn: dynamics_gg.png, with the mu circle
  understeer steering beyond the kinematic angle (delta - atan(L kappa)) against a_lat over steady circles:
             dynamics_understeer.png, with the single-track line K a_lat of the set's tyres
  cost       real-time factor of one car (lidar on, camera off) with and without tyres, in the empty world and in
             bench_maps' basement-like map, and a fleet of 4's against bare MuJoCo's on the same model (mj_step
             alone); medians of interleaved rounds
Pictures go to --out (default docs/).
"""

from __future__ import annotations

import argparse
import math
import tempfile
import time
from pathlib import Path

import numpy as np

from bench_maps import basement_like
from machine_info import machine_line
from racecar_sim.description import VehicleGeometry, load_robot
from racecar_sim.description.vehicle_params import load_vehicle
from racecar_sim.msgs import AckermannDriveStamped
from racecar_sim.runtime import Car, Simulator
from racecar_sim.worlds import load_world
from racecar_sim.worlds.row import starting_row

G = 9.81
L = VehicleGeometry.from_robot(load_robot()).wheelbase
NAVIGATION = "/vesc/ackermann_cmd_mux/input/navigation"
SETS = ("seed", "f1tenth")


def drive(vehicle: str, speed, steer: float, duration: float, rate: float = 100.0) -> np.ndarray:
    """Samples (t, v_forward, yaw rate, a_x, a_y of the centre of mass in the car frame) under a command speed(t)."""
    sim = Simulator(world="empty", camera=False, lidar=False, vehicle=vehicle)
    root = sim.model.body_rootid[sim.car.state.body_id]
    rows: list[list[float]] = []
    com: list[np.ndarray] = []

    def command(now: int) -> None:
        msg = AckermannDriveStamped()
        msg.drive.speed, msg.drive.steering_angle = speed(now * 1e-9), steer
        sim.bus.publish(NAVIGATION, msg)

    def sample(now: int) -> None:
        linear, angular = sim.car.state.base_velocity(local=True)
        _, quat = sim.car.state.base_pose()
        yaw = math.atan2(2 * (quat[0] * quat[3] + quat[1] * quat[2]), 1 - 2 * (quat[2] ** 2 + quat[3] ** 2))
        rows.append([now * 1e-9, float(linear[0]), float(angular[2]), yaw])
        com.append(sim.data.subtree_com[root, :2].copy())

    sim.scheduler.every(50.0, command, "driver")
    sim.scheduler.every(rate, sample, "probe")
    sim.run_until(duration)
    sim.close()
    out = np.array(rows)
    accel = np.zeros((len(out), 2))
    accel[1:-1] = np.diff(np.array(com), 2, axis=0) * rate**2
    c, s = np.cos(out[:, 3]), np.sin(out[:, 3])
    return np.c_[out[:, :3], c * accel[:, 0] + s * accel[:, 1], -s * accel[:, 0] + c * accel[:, 1]]


def circles(vehicle: str, quick: bool) -> list[tuple[float, float, float, float, float]]:
    """(steer, commanded, reached, a_lat in g, R / R0) of the issue's steady circles."""
    table = [(0.3, (1, 2, 3, 4, 5)), (0.1, (2, 4, 4.5, 4.9, 5.2, 6, 8)), (0.0, (6, 8, 12))]
    if quick:
        table = [(0.3, (2, 4)), (0.1, (4, 6))]
    rows = []
    for steer, speeds in table:
        for commanded in speeds:
            samples = drive(vehicle, lambda t, v=commanded: v, steer, 8.0)
            last = samples[samples[:, 0] > 6.0]
            v, r = last[:, 1].mean(), last[:, 2].mean()
            ratio = v / r / (L / math.tan(steer)) if steer else math.nan
            rows.append((steer, commanded, float(v), float(v * r / G), float(ratio)))
    return rows


def gg_points(vehicle: str, quick: bool) -> np.ndarray:
    """(a_x, a_y) in g, 0.1 s means, over circles ramped to 6 m/s in 6 s, then braking in the turn."""
    points = []
    for steer in (0.1, 0.3) if quick else (0.05, 0.1, 0.2, 0.3, -0.2):
        samples = drive(vehicle, lambda t: 0.0 if t > 8.0 else min(6.0, t), steer, 10.0)
        kernel = np.ones(10) / 10
        ax = np.convolve(samples[:, 3], kernel, mode="valid")
        ay = np.convolve(samples[:, 4], kernel, mode="valid")
        points.append(np.c_[ax, ay][5:] / G)
    return np.concatenate(points)


def understeer_points(vehicle: str, quick: bool) -> np.ndarray:
    """(a_lat in g, delta - atan(L kappa) in rad) of steady circles at 0.1 and 0.2 rad."""
    points = []
    for steer in (0.1, 0.2):
        for speed in (1.5, 2.5, 3.5) if quick else (1.0, 1.5, 2.0, 2.5, 3.0, 3.5, 4.0, 4.5):
            samples = drive(vehicle, lambda t, v=speed: v, steer, 8.0)
            last = samples[samples[:, 0] > 6.0]
            v, r = last[:, 1].mean(), last[:, 2].mean()
            points.append((v * r / G, steer - math.atan(L * r / v)))
    return np.array(points)


def fleet(vehicle: str, cars: int) -> Simulator:
    world = load_world("empty")
    return Simulator(
        world=world,
        cars=[
            Car(f"car{k + 1}", camera=False, vehicle=vehicle, spawn=spawn)
            for k, spawn in enumerate(starting_row(world, cars))
        ],
    )


def real_time_factor(vehicle: str, cars: int = 1, seconds: float = 10.0, world: str = "empty") -> float:
    """Sim seconds per wall second of the simulator, nodes and lidar included (the car at rest)."""
    sim = Simulator(world=world, camera=False, vehicle=vehicle) if cars == 1 else fleet(vehicle, cars)
    sim.run_until(0.5)
    start = time.perf_counter()
    sim.run_until(0.5 + seconds)
    wall = time.perf_counter() - start
    sim.close()
    return seconds / wall


def bare_mujoco_factor(vehicle: str, cars: int, seconds: float = 10.0) -> float:
    """The same model stepped by mj_step alone (no nodes, no sensors): the physics' own real-time factor."""
    import mujoco

    sim = fleet(vehicle, cars)
    model, data = sim.model, sim.data
    steps = int(seconds / model.opt.timestep)
    start = time.perf_counter()
    mujoco.mj_step(model, data, nstep=steps)
    wall = time.perf_counter() - start
    sim.close()
    return seconds / wall


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", type=Path, default=Path("docs"))
    parser.add_argument("--quick", action="store_true", help="fewer runs (a smoke test)")
    args = parser.parse_args()
    print(machine_line(), flush=True)  # absolute figures belong to a machine
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    args.out.mkdir(parents=True, exist_ok=True)
    print("| set | steering | commanded (m/s) | reached (m/s) | a_lat (g) | R / R0 |")
    print("|---|---|---|---|---|---|")
    for vehicle in SETS:
        for steer, commanded, reached, a_lat, ratio in circles(vehicle, args.quick):
            print(f"| {vehicle} | {steer:g} | {commanded:g} | {reached:.2f} | {a_lat:.2f} | {ratio:.3f} |")

    fig, axes = plt.subplots(1, len(SETS), figsize=(5 * len(SETS), 5), sharey=True)
    for ax, vehicle in zip(axes, SETS):
        points = gg_points(vehicle, args.quick)
        mu = load_vehicle(vehicle).mu
        angle = np.linspace(0, 2 * np.pi, 200)
        ax.plot(mu * np.cos(angle), mu * np.sin(angle), "k--", lw=1, label=f"mu = {mu:g}")
        ax.scatter(points[:, 1], points[:, 0], s=2, alpha=0.4)
        ax.set(title=vehicle, xlabel="lateral acceleration (g)", aspect="equal", xlim=(-1.3, 1.3), ylim=(-1.3, 1.3))
        ax.legend(loc="lower right")
        print(f"g-g {vehicle}: peak {np.hypot(points[:, 0], points[:, 1]).max():.2f} g (0.1 s means), mu {mu:g}")
    axes[0].set_ylabel("longitudinal acceleration (g)")
    fig.tight_layout()
    fig.savefig(args.out / "dynamics_gg.png", dpi=120)

    fig, ax = plt.subplots(figsize=(6, 4.5))
    for vehicle in SETS:
        points = understeer_points(vehicle, args.quick)
        linear = points[points[:, 0] < 0.4 * load_vehicle(vehicle).mu]
        gradient = np.polyfit(linear[:, 0], linear[:, 1], 1)[0]
        ax.scatter(points[:, 0], points[:, 1], label=f"{vehicle}: K = {gradient:.4f} rad/g (measured)")
        k = load_vehicle(vehicle).understeer_gradient
        grid = np.linspace(0, points[:, 0].max(), 20)
        ax.plot(grid, k * grid, "--", label=f"{vehicle}: single-track K = {k:.4f} rad/g")
        print(f"understeer {vehicle}: measured {gradient:.4f} rad/g, single-track {k:.4f} rad/g")
    ax.set(xlabel="lateral acceleration (g)", ylabel="steering beyond kinematic (rad)", title="Understeer")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(args.out / "dynamics_understeer.png", dpi=120)
    print(f"wrote {args.out / 'dynamics_gg.png'} and {args.out / 'dynamics_understeer.png'}")

    # interleaved rounds, medians: a shared machine's load drifts by more than the difference measured
    rounds = 3 if args.quick else 5
    one: dict[str, list[float]] = {vehicle: [] for vehicle in SETS}
    mapped: dict[str, list[float]] = {vehicle: [] for vehicle in SETS}
    fleets: dict[str, list[float]] = {vehicle: [] for vehicle in SETS}
    basement = str(basement_like(Path(tempfile.mkdtemp()), 0))
    for _ in range(rounds):
        for vehicle in SETS:
            one[vehicle].append(real_time_factor(vehicle))
            mapped[vehicle].append(real_time_factor(vehicle, world=basement))
            fleets[vehicle].append(real_time_factor(vehicle, cars=4) / bare_mujoco_factor(vehicle, cars=4))
    for label, runs in (("one car (lidar, no camera)", one), ("one car in a basement-like map", mapped)):
        seed_rtf, tyre_rtf = float(np.median(runs["seed"])), float(np.median(runs["f1tenth"]))
        ratio = tyre_rtf / seed_rtf
        print(f"{label}: seed {seed_rtf:.1f}x, f1tenth {tyre_rtf:.1f}x real time, ratio {ratio:.2f}")
    for vehicle in SETS:
        print(f"fleet of 4, {vehicle}: real-time factor / bare MuJoCo's {float(np.median(fleets[vehicle])):.2f}")


if __name__ == "__main__":
    main()
