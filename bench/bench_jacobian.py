"""One physics step of a tunnel fleet with MuJoCo's dense constraint Jacobian (the builder's) against its sparse one:
`python bench/bench_jacobian.py [--cars 8 16 24 39] [--rounds 5]`.

Each fleet stands in its starting row for 0.5 s (wheels still), then 400 steps are timed from the same state with
each Jacobian in turn, interleaved; the best round of each is printed, and their ratio (dense / sparse).
"""

from __future__ import annotations

import argparse
import time

import mujoco
import numpy as np

from machine_info import machine_line
from racecar_sim.runtime import Car, Simulator
from racecar_sim.worlds import load_world
from racecar_sim.worlds.row import starting_row

STEPS = 400
FULL = mujoco.mjtState.mjSTATE_FULLPHYSICS


def step_times(cars: int, rounds: int) -> tuple[int, float, float]:
    """nv, and the best ms per step with the dense and with the sparse Jacobian."""
    world = load_world("tunnel", None, [], None)
    fleet = [Car(f"car{k + 1}", spawn=spawn, camera=False) for k, spawn in enumerate(starting_row(world, cars))]
    with Simulator(world=world, cars=fleet) as sim:
        model, data = sim.model, sim.data
        mujoco.mj_step(model, data, nstep=200)
        state = np.empty(mujoco.mj_stateSize(model, FULL))
        mujoco.mj_getState(model, data, state, FULL)
        best = {
            jacobian: float("inf") for jacobian in (mujoco.mjtJacobian.mjJAC_DENSE, mujoco.mjtJacobian.mjJAC_SPARSE)
        }
        for _ in range(rounds):
            for jacobian in best:
                model.opt.jacobian = jacobian
                mujoco.mj_setState(model, data, state, FULL)
                start = time.perf_counter()
                mujoco.mj_step(model, data, nstep=STEPS)
                best[jacobian] = min(best[jacobian], (time.perf_counter() - start) / STEPS * 1e3)
        return model.nv, best[mujoco.mjtJacobian.mjJAC_DENSE], best[mujoco.mjtJacobian.mjJAC_SPARSE]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--cars", type=int, nargs="+", default=[8, 16, 24, 39])
    parser.add_argument("--rounds", type=int, default=5)
    args = parser.parse_args()
    print(machine_line(), flush=True)  # absolute figures belong to a machine
    print(f"{'cars':>4}  {'nv':>4}  {'dense ms':>8}  {'sparse ms':>9}  dense/sparse")
    for cars in args.cars:
        nv, dense, sparse = step_times(cars, args.rounds)
        print(f"{cars:>4}  {nv:>4}  {dense:>8.3f}  {sparse:>9.3f}  {dense / sparse:.2f}", flush=True)


if __name__ == "__main__":
    main()
