"""One physics step of a fleet with each constraint Jacobian and solver (physics/contact_solver.py chooses):
`python bench/bench_jacobian.py [--cars 8 16 32 64 128 256] [--rounds 3]`.

Each fleet stands in `empty`, 16 cars a row (1.5 m apart, rows 1 m apart), for 0.25 s with its wheels still; then 100
steps are timed from the same state with the dense Jacobian and Newton, the sparse Jacobian and Newton (MuJoCo's own
choice from 60 dofs on) and the sparse Jacobian and CG, in turn, interleaved; the best round of each is printed, and
the ratios to sparse Newton. `chosen` names what the fleet steps with.
"""

from __future__ import annotations

import argparse
import time

import mujoco
import numpy as np

from machine_info import machine_line
from racecar_sim.runtime import Car, Simulator
from racecar_sim.worlds import Spawn

STEPS = 100
ROW = 16  # cars a row
FULL = mujoco.mjtState.mjSTATE_FULLPHYSICS
JAC, SOLVER = mujoco.mjtJacobian, mujoco.mjtSolver
WAYS = {
    "dense Newton": (JAC.mjJAC_DENSE, SOLVER.mjSOL_NEWTON),
    "sparse Newton": (JAC.mjJAC_SPARSE, SOLVER.mjSOL_NEWTON),
    "sparse CG": (JAC.mjJAC_SPARSE, SOLVER.mjSOL_CG),
}


def step_times(cars: int, rounds: int) -> tuple[int, str, dict[str, float]]:
    """nv, the way the fleet steps, and the best ms per step of each way."""
    fleet = [
        Car(f"car{k + 1}", spawn=Spawn(1.5 * (k % ROW), 1.0 * (k // ROW), 0.05, 0.0), camera=False) for k in range(cars)
    ]
    with Simulator(world="empty", cars=fleet) as sim:
        model, data = sim.model, sim.data
        chosen = next(name for name, way in WAYS.items() if way == (model.opt.jacobian, model.opt.solver))
        mujoco.mj_step(model, data, nstep=100)
        state = np.empty(mujoco.mj_stateSize(model, FULL))
        mujoco.mj_getState(model, data, state, FULL)
        best = dict.fromkeys(WAYS, float("inf"))
        for _ in range(rounds):
            for name, (jacobian, solver) in WAYS.items():
                model.opt.jacobian, model.opt.solver = jacobian, solver
                mujoco.mj_setState(model, data, state, FULL)
                start = time.perf_counter()
                mujoco.mj_step(model, data, nstep=STEPS)
                best[name] = min(best[name], (time.perf_counter() - start) / STEPS * 1e3)
        return model.nv, chosen, best


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--cars", type=int, nargs="+", default=[8, 16, 32, 64, 128, 256])
    parser.add_argument("--rounds", type=int, default=3)
    args = parser.parse_args()
    print(machine_line(), flush=True)  # absolute figures belong to a machine
    print(f"{'cars':>4}  {'nv':>4}  " + "  ".join(f"{name + ' ms':>16}" for name in WAYS) + "  chosen / sparse Newton")
    for cars in args.cars:
        nv, chosen, best = step_times(cars, args.rounds)
        times = "  ".join(f"{best[name]:>16.3f}" for name in WAYS)
        print(f"{cars:>4}  {nv:>4}  {times}  {chosen}: {best[chosen] / best['sparse Newton']:.2f}", flush=True)


if __name__ == "__main__":
    main()
