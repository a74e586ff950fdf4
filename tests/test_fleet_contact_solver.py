"""Cars that touch wheel to wheel: the contact solver finds the optimum, so a pile-up stays a crash, not a launch
(physics/contact_solver.py: the dense Jacobian up to 16 cars, the sparse one with CG above).

The state is the tunnel's 8-car wall-follow run (`racecar-sim run --world tunnel --cars 8`, seed 0) at 53.2025 s:
car4 reversing, its rear wheels against car5's front wheels. With MuJoCo's automatic (here sparse) Jacobian, its
Newton solver stalled there at the iteration cap, far from the optimum: 3e4 N on two wheel contacts threw car4 3 m
into the air within 0.2 s, and the run diverged at 54.57 s."""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
import pytest

from racecar_sim import Car, Simulator
from racecar_sim.physics.contact_solver import choose_contact_solver
from racecar_sim.worlds import load_world, starting_row

STATE = Path(__file__).parent / "data" / "tunnel8_wheel_to_wheel.npz"


@pytest.fixture(scope="module")
def wheel_to_wheel():
    world = load_world("tunnel", None, [], None)
    cars = [Car(f"car{k + 1}", spawn=spawn, camera=False) for k, spawn in enumerate(starting_row(world, 8))]
    sim = Simulator(world=world, cars=cars)
    saved = np.load(STATE)
    model, data = sim.model, sim.data
    assert (model.nq, model.nv, model.nu) == (len(saved["qpos"]), len(saved["qvel"]), len(saved["ctrl"]))
    data.time = float(saved["time"])
    for field in ("qpos", "qvel", "act", "ctrl", "qacc_warmstart"):
        getattr(data, field)[:] = saved[field]
    sim.poses_changed()  # the map's walls held near the cars where they are now
    mujoco.mj_forward(model, data)
    yield sim
    sim.close()


def _car_dofs(model: mujoco.MjModel, car: str) -> np.ndarray:
    root = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, f"{car}/base_link")
    return np.flatnonzero(model.body_rootid[model.dof_bodyid] == root)


def _solved_with(sim: Simulator, solver: mujoco.mjtSolver, jacobian: mujoco.mjtJacobian | None = None) -> np.ndarray:
    """qacc as `solver` (with `jacobian`, or the scene's) solves the constraint problem of the state."""
    opt = sim.model.opt
    data = mujoco.MjData(sim.model)
    mujoco.mj_copyData(data, sim.model, sim.data)
    saved = opt.solver, opt.jacobian
    opt.solver, opt.jacobian = solver, saved[1] if jacobian is None else jacobian
    try:
        mujoco.mj_forward(sim.model, data)
    finally:
        opt.solver, opt.jacobian = saved
    return data.qacc.copy()


def _cost(sim: Simulator, qacc: np.ndarray) -> float:
    """The objective MuJoCo's constraint solvers minimise (Gauss's principle plus the constraints' soft costs)."""
    model, data = sim.model, sim.data
    away = qacc - data.qacc_smooth
    weighted = np.zeros(model.nv)
    mujoco.mj_mulM(model, data, weighted, away)
    jar = np.zeros(data.nefc)
    mujoco.mj_mulJacVec(model, data, jar, qacc)
    constraints = np.zeros(1)
    mujoco.mj_constraintUpdate(model, data, jar - data.efc_aref[: data.nefc], constraints, 0)
    return 0.5 * float(away @ weighted) + float(constraints[0])


def test_the_two_cars_touch_only_wheel_to_wheel(wheel_to_wheel):
    model, data = wheel_to_wheel.model, wheel_to_wheel.data

    def name(geom: int) -> str:
        return mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_GEOM, geom) or ""

    pairs = {tuple(sorted(map(name, c.geom))) for c in data.contact[: data.ncon]}
    assert {p for p in pairs if any(n.startswith(("car4/", "car5/")) for n in p)} == {
        ("car4/left_rear_wheel_collision", "car5/left_front_wheel_collision"),
        ("car4/right_rear_wheel_collision", "car5/right_front_wheel_collision"),
    }


def test_the_fleet_steps_with_the_dense_jacobian_and_newton(wheel_to_wheel):
    opt = wheel_to_wheel.model.opt
    assert (opt.jacobian, opt.solver) == (mujoco.mjtJacobian.mjJAC_DENSE, mujoco.mjtSolver.mjSOL_NEWTON)


def test_the_default_solver_reaches_the_optimum_other_solvers_find(wheel_to_wheel):
    """The problem is convex: the preset's Newton must do at least as well as CG and PGS (other algorithms), and as
    the sparse Jacobian's CG (the choice above 16 cars), and agree with them on the two cars' accelerations. The
    stalled solve (MuJoCo's own choice, the sparse Jacobian's Newton) cost 1.0e7 here against the optimum's 5.6e4."""
    sim = wheel_to_wheel
    newton = _solved_with(sim, mujoco.mjtSolver.mjSOL_NEWTON)
    sparse = mujoco.mjtJacobian.mjJAC_SPARSE
    others = [
        (mujoco.mjtSolver.mjSOL_CG, None),
        (mujoco.mjtSolver.mjSOL_PGS, None),
        (mujoco.mjtSolver.mjSOL_CG, sparse),
    ]
    for other, jacobian in others:
        qacc = _solved_with(sim, other, jacobian)
        assert _cost(sim, newton) <= _cost(sim, qacc) * (1 + 1e-6), (other, jacobian)
        assert _cost(sim, qacc) <= _cost(sim, newton) * (1 + 1e-3), (other, jacobian)
        for car in ("car4", "car5"):
            chassis = _car_dofs(sim.model, car)[:6]  # its free joint
            np.testing.assert_allclose(newton[chassis], qacc[chassis], rtol=0.02, atol=0.1, err_msg=f"{car} {other}")


def test_the_pile_up_stays_on_the_ground(wheel_to_wheel):
    """20 ms on (8 steps), neither car leaves the ground or moves faster than a car drives (the stalled solver had
    car4 at 155 m/s or rad/s and 0.25 m up by then)."""
    sim = wheel_to_wheel
    model = sim.model
    data = mujoco.MjData(model)
    mujoco.mj_copyData(data, model, sim.data)
    mujoco.mj_step(model, data, nstep=8)
    assert np.isfinite(data.qpos).all() and np.isfinite(data.qvel).all()
    for car in ("car4", "car5"):
        free = _car_dofs(model, car)[:6]
        assert np.abs(data.qvel[free]).max() < 5.0, (car, data.qvel[free])
        joint = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, f"{car}/root")
        assert data.qpos[model.jnt_qposadr[joint] + 2] < 0.05, car


@pytest.mark.parametrize(("dofs", "jacobian", "solver"), [(24, "DENSE", "NEWTON"), (192, "DENSE", "NEWTON"),
                                                          (204, "SPARSE", "CG")])  # fmt: skip
def test_a_fleet_of_up_to_16_cars_takes_the_dense_jacobian_above_it_sparse_cg(dofs, jacobian, solver):
    spec = mujoco.MjSpec()
    for k in range(dofs // 12):  # a car's 12 dofs: a free joint and six hinges
        body = spec.worldbody.add_body(name=f"car{k}", pos=[2.0 * k, 0, 1])
        body.add_freejoint()
        body.add_geom(size=[0.1, 0, 0])
        for j in range(6):
            body = body.add_body(name=f"car{k}_link{j}")
            body.add_joint(name=f"car{k}_hinge{j}")
            body.add_geom(size=[0.05, 0, 0])
    model = spec.compile()
    assert model.nv == dofs
    model.opt.solver = mujoco.mjtSolver.mjSOL_NEWTON
    choose_contact_solver(model)
    assert model.opt.jacobian == getattr(mujoco.mjtJacobian, f"mjJAC_{jacobian}")
    assert model.opt.solver == getattr(mujoco.mjtSolver, f"mjSOL_{solver}")
