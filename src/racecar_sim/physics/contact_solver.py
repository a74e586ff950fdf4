"""The constraint Jacobian and solver a compiled scene steps with, by its number of dofs.

MuJoCo's automatic choice takes the sparse Jacobian from 60 dofs on (a fleet of 5 cars and more). There its Newton
solver with pyramidal cones (MuJoCo 4.0.0) can stall far from the optimum on an island of two cars touching wheel to
wheel: at its iteration cap, its cost 13 times the optimum's, with 3e4 N on two wheel contacts, which throw a car
into the air (`racecar-sim run --world tunnel --cars 8`: car4 at 53.2 s, NaN at 54.57 s). The dense Jacobian's
Newton, CG and PGS, and the sparse one's CG, all find the optimum there. So a scene takes the dense Jacobian up to
DENSE_MAX_DOFS (up to 4 cars that was MuJoCo's choice already: their runs are unchanged bit for bit), and above it,
where the dense Hessian's cost grows with the cube of the dofs, the sparse Jacobian with CG instead of Newton
(bench/bench_jacobian.py).
"""

from __future__ import annotations

import mujoco

DENSE_MAX_DOFS = 192  # 16 cars of 12 dofs: a dense step costs 1.25x the sparse Newton's (3.5x at 64 cars, 31x at 256)


def choose_contact_solver(model: mujoco.MjModel) -> None:
    """Set the model's Jacobian (dense up to DENSE_MAX_DOFS, else sparse) and, above it, CG where Newton was asked."""
    if model.nv <= DENSE_MAX_DOFS:
        model.opt.jacobian = mujoco.mjtJacobian.mjJAC_DENSE
        return
    model.opt.jacobian = mujoco.mjtJacobian.mjJAC_SPARSE
    if model.opt.solver == mujoco.mjtSolver.mjSOL_NEWTON:
        model.opt.solver = mujoco.mjtSolver.mjSOL_CG
