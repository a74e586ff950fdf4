"""MuJoCo Warp worlds (envs/batch_warp.py) against CPU MuJoCo's mj_step on the same model, state and controls.

Runs on Warp's CPU device, so no GPU is needed (mujoco-warp from the [gpu] extra is: skipped without it). The first
run compiles Warp's kernels (~30 s on 2 cores, then cached in ~/.cache/warp: ~3 s); RACECAR_SIM_TEST_WARP=0 skips
it. The model adaptation tests need only MuJoCo and always run.
"""

from __future__ import annotations

import copy
import importlib.util
import os

import mujoco
import numpy as np
import pytest

from racecar_sim.core.errors import ConfigError
from racecar_sim.envs.batch import DriveBatch
from racecar_sim.envs.batch_reward import CrashTable
from racecar_sim.envs.batch_warp import warp_model
from racecar_sim.envs.crash import SUPPORT_NORMAL_Z
from racecar_sim.physics.builder import ROOT_JOINT
from racecar_sim.runtime.simulator import Simulator

STEPS = 200  # 0.5 s at the default preset's 2.5 ms
# wheel velocity setpoints (rad/s: rear left/right, front left/right) and steering hinge angles (rad)
CTRLS = np.array(
    [[0, 0, 0, 0, 0, 0], [20, 20, 20, 20, 0, 0], [15, 15, 15, 15, 0.3, 0.3], [-10, -10, -10, -10, -0.25, -0.25]], float
)

needs_warp = pytest.mark.skipif(
    importlib.util.find_spec("mujoco_warp") is None or os.environ.get("RACECAR_SIM_TEST_WARP") == "0",
    reason="needs mujoco-warp (the [gpu] extra); RACECAR_SIM_TEST_WARP=0 skips it",
)


@pytest.fixture(scope="module")
def sim() -> Simulator:
    sim = Simulator(world="empty", camera=False, lidar=False, sensor_noise=False)
    sim.reset(0)
    return sim


def _cpu_rollout(model: mujoco.MjModel, data: mujoco.MjData, ctrls: np.ndarray, steps: int) -> list[mujoco.MjData]:
    out = []
    for ctrl in ctrls:
        d = copy.copy(data)
        d.ctrl[:] = ctrl
        mujoco.mj_step(model, d, nstep=steps)
        out.append(d)
    return out


def test_warp_model_drives_as_the_pid_model(sim):
    """The fixed-gain copy of the pid actuators gives the same trajectories on CPU MuJoCo (to rounding)."""
    adapted = warp_model(sim.model)
    assert not (adapted.actuator_gaintype == mujoco.mjtGain.mjGAIN_PID).any()
    assert (sim.model.actuator_gaintype == mujoco.mjtGain.mjGAIN_PID).all()  # the original is untouched
    for a, b in zip(_cpu_rollout(sim.model, sim.data, CTRLS, STEPS), _cpu_rollout(adapted, sim.data, CTRLS, STEPS)):
        np.testing.assert_allclose(a.qpos, b.qpos, atol=1e-12)
        np.testing.assert_allclose(a.qvel, b.qvel, atol=1e-12)
    assert np.abs(_cpu_rollout(sim.model, sim.data, CTRLS[1:2], STEPS)[0].qvel[0]) > 0.5  # the car does drive


def test_warp_model_refuses_a_pid_with_integral(sim):
    model = copy.copy(sim.model)
    model.actuator_gainprm[4, 0] = 2.0  # ki of a steering controller
    with pytest.raises(ConfigError, match="integral"):
        warp_model(model)


@needs_warp
def test_warp_worlds_match_cpu_mujoco(sim):
    """4 worlds with different constant controls, 0.5 s: Warp computes in float32 (eps 1.2e-7), whose rounding
    accumulates over 200 steps; seen: base position within 4e-7 m, wheel angles (up to ~10 rad) within 1e-4 rad,
    qvel within 5e-6. Tolerances: 1e-5 m on the base, 1e-3 on any qpos/qvel entry."""
    from racecar_sim.envs.batch_warp import WarpWorlds

    model, data = sim.model, sim.data
    root = int(model.jnt_qposadr[model.joint(sim.car.names.mj(ROOT_JOINT)).id])
    worlds = WarpWorlds(model, data, len(CTRLS), device="warp-cpu")
    worlds.set_ctrl(CTRLS)
    worlds.step(STEPS)
    qpos, qvel = worlds.qpos(), worlds.qvel()
    expected = _cpu_rollout(model, data, CTRLS, STEPS)
    for w, d in enumerate(expected):
        np.testing.assert_allclose(qpos[w, root : root + 3], d.qpos[root : root + 3], atol=1e-5, err_msg=f"world {w}")
        np.testing.assert_allclose(qpos[w], d.qpos, atol=1e-3, err_msg=f"world {w}")
        np.testing.assert_allclose(qvel[w], d.qvel, atol=1e-3, err_msg=f"world {w}")
    xpos, xmat = worlds.body_pose(sim.car.state.body_id)
    np.testing.assert_allclose(xpos, [d.xpos[sim.car.state.body_id] for d in expected], atol=1e-5)
    np.testing.assert_allclose(xmat, [d.xmat[sim.car.state.body_id].reshape(3, 3) for d in expected], atol=1e-4)
    velocity = np.zeros((len(expected), 6))
    for w, d in enumerate(expected):
        mujoco.mj_objectVelocity(model, d, mujoco.mjtObj.mjOBJ_XBODY, sim.car.state.body_id, velocity[w], 1)
    np.testing.assert_allclose(worlds.body_velocity(sim.car.state.body_id), velocity, atol=1e-4)
    assert velocity[1, 3] > 0.5 and velocity[3, 3] < -0.2  # forward and reverse speeds

    # reset: world 1 rolled onto its side, world 3 upside down (crashes: the chassis on the ground), 0 and 2 at
    # the start, all at rest
    start = np.tile(data.qpos, (len(CTRLS), 1))
    start[[1, 3], root + 2] -= 0.05
    start[1, root + 3 : root + 7] = [np.sqrt(0.5), np.sqrt(0.5), 0.0, 0.0]
    start[3, root + 3 : root + 7] = [0.0, 1.0, 0.0, 0.0]
    worlds.reset(start, np.zeros((len(CTRLS), model.nv)))
    worlds.step(1)
    wheels = [model.body(sim.car.names.mj(w.link)).id for w in sim.car.servo.geometry.wheels]
    table = CrashTable(model, sim.car.state.body_id, wheels)
    cpu = []
    for row in start:
        d = copy.copy(data)
        d.qpos[:], d.qvel[:], d.ctrl[:], d.qacc_warmstart[:] = row, 0.0, 0.0, 0.0
        mujoco.mj_step(model, d)
        cpu.append(table.crashed(d))
    assert cpu == [False, True, False, True]
    np.testing.assert_array_equal(worlds.crashed(table.kind, SUPPORT_NORMAL_Z), cpu)
    after = worlds.qpos()
    np.testing.assert_array_equal(after[2], after[0])  # reset worlds with the same state step alike
    np.testing.assert_allclose(after[0], data.qpos, atol=1e-4)  # at rest after one step from the start


@needs_warp
def test_drive_batch_on_warp_matches_the_cpu_batch():
    """DriveBatch(device="warp-cpu") against the CPU batch, same seeds and random actions, 20 control steps of 50 ms;
    worlds 0 and 2 end their episodes (truncated) after 3 steps, so the worlds' crash checks (50 Hz from each one's
    episode start) fall at different instants of a control period. The actions are a random walk, as a policy's
    are: actions drawn afresh each step (full forward to full reverse in 50 ms) make the wheels slip chaotically,
    and there a 1e-5 m/s change of qvel in CPU MuJoCo alone grows to centimetres within 10 steps. Even for random
    walks, float32 can tip a wheel-slip event: of 6 walks tried (20 and 50 Hz), 2 grew from ~1e-7 m to ~2e-3 m
    after one (also at 50 Hz, where all worlds check at the period's end); this walk (seed 10) has none.
    Seen: car bases within 3.2e-7 m, speeds within 2.8e-6 m/s. Tolerances: 1e-4 m, 1e-4 m/s; same flags."""
    actions = np.clip(np.cumsum(np.random.default_rng(10).normal(0, 0.1, size=(20, 4, 2)), 0), -1, 1)
    batches = [
        DriveBatch(4, world="empty", seeds=[3, 4, 5, 6], control_rate=20.0, max_episode_steps=3, device=device)
        for device in ("cpu", "warp-cpu")
    ]
    cpu, gpu = batches
    for batch in batches:
        batch.reset()
        batch.steps[1::2] = -100  # worlds 1 and 3 go on
    root = slice(cpu.root_qpos, cpu.root_qpos + 3)
    for k in range(len(actions)):
        (_, _, cpu_terminated, cpu_truncated, _), (_, _, terminated, truncated, _) = (
            b.step(actions[k]) for b in batches
        )
        np.testing.assert_array_equal(terminated, cpu_terminated, err_msg=f"step {k}")
        np.testing.assert_array_equal(truncated, cpu_truncated, err_msg=f"step {k}")
        np.testing.assert_allclose(gpu.qpos[:, root], cpu.qpos[:, root], atol=1e-4, err_msg=f"step {k}")
        np.testing.assert_allclose(gpu.speed, cpu.speed, atol=1e-4, err_msg=f"step {k}")
        if k == 2:
            assert list(truncated) == [True, False, True, False]
            batches[0].max_episode_steps = batches[1].max_episode_steps = None
    assert len(set(cpu.time_ns.tolist())) == 2  # the worlds' episode times differ
    assert np.abs(cpu.qpos[1::2, root][:, :2]).max() > 0.2  # the cars did drive
    for batch in batches:
        batch.close()


def test_drive_batch_warp_device_without_gpu_is_one_line_error():
    if importlib.util.find_spec("warp") is not None:
        import warp

        warp.config.quiet = True
        if warp.get_cuda_device_count():
            pytest.skip("this machine has a CUDA GPU")
    with pytest.raises(ConfigError) as err:
        DriveBatch(2, world="empty", device="warp")
    assert "\n" not in str(err.value) and "[gpu]" in str(err.value)
