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
from racecar_sim.physics.tyre_callback import PACEJKA
from racecar_sim.physics.tyre_warp import needs_callbacks, rate_limited_actuators, tyre_rows
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


@pytest.fixture(scope="module")
def tyre_sim() -> Simulator:
    sim = Simulator(world="empty", camera=False, lidar=False, sensor_noise=False, vehicle="f1tenth")
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


def test_only_a_set_with_tyres_or_rate_limits_gets_warp_callbacks(sim, tyre_sim):
    """seed's model gets no Warp callback (MuJoCo Warp steps it as before); f1tenth's four wheels, each with its own
    touch sensor, and its six rate-limited setpoints do."""
    assert not needs_callbacks(sim.model)
    model, car = tyre_sim.model, tyre_sim.car
    rows = tyre_rows(model)
    wheels = {model.body(car.names.mj(w.link)).id for w in car.servo.geometry.wheels}
    assert set(rows[:, 0].astype(int).tolist()) == wheels and len(rows) == 4
    assert sorted(rows[:, 2].astype(int).tolist()) == sorted(
        model.sensor_adr[model.sensor_type == mujoco.mjtSensor.mjSENS_TOUCH].tolist()
    )
    assert len(rate_limited_actuators(model)) == model.nu == 6


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
def test_warp_tyres_match_the_cpu_callbacks_through_a_circle_and_a_steer(tyre_sim):
    """f1tenth's tyres and rate limits in MuJoCo Warp (physics/tyre_warp.py) against CPU MuJoCo with the compiled
    callbacks: 2 worlds from rest, wheel setpoints of 3.5 and 4 m/s (reached through a_max) at a constant steer of
    0.25 and 0.15 rad for 1 s, then steered to -0.1 rad for 0.4 s. The circle slips (R/R0 1.13 for world 0) and the
    steer reverses the yaw rate, so the slip angles, slip ratios, loads and rate limits all act (without the tyre
    kernels the Warp car does not move: the wheels touch the ground without friction).
    Warp computes in float32 (eps 1.2e-7): its rounding grows through the spin-up, where the car hops on the
    spawn drop and pitches under a_max (wheel loads 0 to 65 N). Seen: bases within 1.1e-3 m, yaw rates within
    2.4e-2 rad/s (at 1.3 rad/s and rising fast, 0.7 s), 3e-3 rad/s in the steady circle, speeds within 7.5e-3 m/s.
    Tolerances: 5e-3 m, 0.06 rad/s (2.5 % of the 2.4 rad/s peak), 0.02 m/s; steady circle means within 1e-2."""
    from racecar_sim.envs.batch_warp import WarpWorlds

    model, data, body = tyre_sim.model, tyre_sim.data, tyre_sim.car.state.body_id
    circle = np.array([[70, 70, 70, 70, 0.25, 0.25], [80, 80, 80, 80, 0.15, 0.15]], float)
    steer = circle.copy()
    steer[:, 4:] = -0.1
    worlds = WarpWorlds(model, data, len(circle), device="warp-cpu")
    cpu = [copy.copy(data) for _ in circle]
    every = 20  # 50 ms
    cpu_rates, warp_rates, cpu_speeds = [], [], []
    for ctrl, steps in ((circle, 400), (steer, 160)):
        worlds.set_ctrl(ctrl)
        for _ in range(steps // every):
            worlds.step(every)
            velocity = np.zeros((len(cpu), 6))
            for w, d in enumerate(cpu):
                d.ctrl[:] = ctrl[w]
                mujoco.mj_step(model, d, nstep=every)
                mujoco.mj_objectVelocity(model, d, mujoco.mjtObj.mjOBJ_XBODY, body, velocity[w], 1)
            on_warp = worlds.body_velocity(body)
            time = cpu[0].time
            np.testing.assert_allclose(worlds.body_pose(body)[0], [d.xpos[body] for d in cpu], atol=5e-3, err_msg=time)
            np.testing.assert_allclose(on_warp[:, 2], velocity[:, 2], atol=0.06, err_msg=f"yaw rate at {time}")
            np.testing.assert_allclose(on_warp[:, 3], velocity[:, 3], atol=0.02, err_msg=f"speed at {time}")
            cpu_rates.append(velocity[:, 2])
            warp_rates.append(on_warp[:, 2])
            cpu_speeds.append(velocity[:, 3])
    rates, speeds = np.array(cpu_rates), np.array(cpu_speeds)
    steady = slice(15, 20)  # 0.75 to 1 s: the circle
    np.testing.assert_allclose(np.array(warp_rates)[steady].mean(0), rates[steady].mean(0), rtol=1e-2)
    wheelbase = tyre_sim.car.servo.geometry.wheelbase
    radius = speeds[steady].mean(0) / rates[steady].mean(0)
    assert radius[0] / (wheelbase / np.tan(0.25)) > 1.05  # the tyres slip: wider than the kinematic circle
    assert rates[-1].max() < -0.5 < 1.2 < rates[steady].min()  # the steer reversed the turn
    # the wheel loads the next step reads are the last step's touch sensors; a reset world takes those given
    touch = model.sensor_adr[model.sensor_type == mujoco.mjtSensor.mjSENS_TOUCH]
    assert worlds.tyres is not None
    np.testing.assert_allclose(worlds.tyres.loads.numpy(), [d.sensordata[touch] for d in cpu], rtol=0.05, atol=0.5)
    given = np.arange(1.0, model.nsensordata + 1.0)[None]
    before = worlds.tyres.loads.numpy()
    worlds.reset(np.array([data.qpos]), np.zeros((1, model.nv)), np.array([1]), sensordata=given)
    after = worlds.tyres.loads.numpy()
    np.testing.assert_array_equal(after[1], given[0, tyre_rows(model)[:, 2].astype(int)])
    np.testing.assert_array_equal(after[0], before[0])


@needs_warp
def test_warp_pacejka_tyres_match_the_cpu_callbacks(tmp_path):
    """ForzaETH's NUC2 magic-formula fit (front B C D E 4.80 2.16 0.650 0.373, rear 20.0 1.5 0.618 0) in MuJoCo Warp
    against CPU MuJoCo with the callbacks: 2 worlds from rest at 2.5 m/s and 0.25 rad, 2 m/s and -0.3 rad, 1 s.
    The circles understeer strongly (R/R0 1.6 at 2.5 m/s). Seen: bases within 1.8e-4 m, yaw rates within 1.7e-3
    rad/s, speeds within 9.3e-4 m/s. Tolerances: 1e-3 m, 0.01 rad/s, 5e-3 m/s. (Spinning the steep rear curve up
    to 4 m/s, past the peak of its slip ratio, magnifies float32 rounding: 1.6 cm apart after 1.4 s. The test stays
    below that.)"""
    from racecar_sim.envs.batch_warp import WarpWorlds

    path = tmp_path / "nuc2.yaml"
    path.write_text("C_Pf: [4.80, 2.16, 0.650, 0.373]\nC_Pr: [20.0, 1.5, 0.618, 0.0]\n")
    sim = Simulator(world="empty", camera=False, lidar=False, sensor_noise=False, vehicle=str(path))
    sim.reset(0)
    model, data, body = sim.model, sim.data, sim.car.state.body_id
    assert (tyre_rows(model)[:, 7] == PACEJKA).all()
    ctrl = np.array([[50, 50, 50, 50, 0.25, 0.25], [40, 40, 40, 40, -0.3, -0.3]], float)
    worlds = WarpWorlds(model, data, len(ctrl), device="warp-cpu")
    worlds.set_ctrl(ctrl)
    cpu = [copy.copy(data) for _ in ctrl]
    velocity = np.zeros((len(cpu), 6))
    for _ in range(10):
        worlds.step(40)
        for w, d in enumerate(cpu):
            d.ctrl[:] = ctrl[w]
            mujoco.mj_step(model, d, nstep=40)
            mujoco.mj_objectVelocity(model, d, mujoco.mjtObj.mjOBJ_XBODY, body, velocity[w], 1)
        on_warp, time = worlds.body_velocity(body), cpu[0].time
        np.testing.assert_allclose(worlds.body_pose(body)[0], [d.xpos[body] for d in cpu], atol=1e-3, err_msg=time)
        np.testing.assert_allclose(on_warp[:, 2], velocity[:, 2], atol=0.01, err_msg=f"yaw rate at {time}")
        np.testing.assert_allclose(on_warp[:, 3], velocity[:, 3], atol=5e-3, err_msg=f"speed at {time}")
    radius = velocity[0, 3] / velocity[0, 2]
    assert radius / (sim.car.servo.geometry.wheelbase / np.tan(0.25)) > 1.4  # the magic formula's understeer
    sim.close()


@needs_warp
def test_a_rate_limited_setpoint_ramps_at_its_limit_on_warp():
    """A `user` dyntype actuator (physics/actuation.py's rate limit: dynprm low, high, timestep) without any tyre:
    its activation ramps towards the command at the limit (2 /s: 0.4 after 0.2 s, and -0.4 towards -0.5), as CPU
    MuJoCo's with the compiled callback, then holds the command; the joint it drives follows as on CPU."""
    from racecar_sim.envs.batch_warp import WarpWorlds
    from racecar_sim.physics.tyre_callback import install_actuator_dynamics

    install_actuator_dynamics()
    model = mujoco.MjModel.from_xml_string(
        "<mujoco><option timestep='0.002'/><worldbody><body><joint name='j' axis='0 0 1'/>"
        "<geom size='.1' pos='.2 0 0'/></body></worldbody><actuator><general joint='j' dyntype='user' "
        "dynprm='-2 2 0.002' gainprm='1' biastype='affine' biasprm='0 -1 -0.1'/></actuator></mujoco>"
    )
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    commands = np.array([[1.0], [-0.5]])
    worlds = WarpWorlds(model, data, len(commands), device="warp-cpu")
    worlds.set_ctrl(commands)
    cpu = [copy.copy(data) for _ in commands]
    for steps, expected in ((100, [0.4, -0.4]), (200, [1.0, -0.5])):
        worlds.step(steps)
        for d, command in zip(cpu, commands):
            d.ctrl[:] = command
            mujoco.mj_step(model, d, nstep=steps)
        np.testing.assert_allclose(worlds.act()[:, 0], expected, atol=1e-5)
        np.testing.assert_allclose([d.act[0] for d in cpu], expected, atol=1e-9)
        np.testing.assert_allclose(worlds.qpos()[:, 0], [d.qpos[0] for d in cpu], atol=1e-5)


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


@needs_warp
def test_drive_batch_on_warp_with_tyres_matches_the_cpu_batch():
    """DriveBatch(vehicle="f1tenth") on Warp against the CPU batch: 2 worlds at 0.9 of a 4 m/s top speed, steering
    a random walk around half lock, 14 control steps of 50 ms; world 0 is reset after 7 (its wheel loads go back
    to the reset state's with it) and starts again from rest.
    Seen: car bases within 2.2e-5 m, speeds within 3.2e-4 m/s. Tolerances: 5e-4 m, 5e-3 m/s."""
    rng = np.random.default_rng(10)
    steering = np.clip(0.5 + np.cumsum(rng.normal(0, 0.1, size=(14, 2)), 0), -1, 1)
    actions = np.stack([np.full((14, 2), 0.9), steering], axis=-1)
    batches = [
        DriveBatch(2, world="empty", seeds=[3, 4], control_rate=20.0, device=device, vehicle="f1tenth", max_speed=4.0)
        for device in ("cpu", "warp-cpu")
    ]
    cpu, gpu = batches
    for batch in batches:
        batch.reset()
    root = slice(cpu.root_qpos, cpu.root_qpos + 3)
    speeds = []
    for k in range(len(actions)):
        for batch in batches:
            batch.step(actions[k])
        np.testing.assert_allclose(gpu.qpos[:, root], cpu.qpos[:, root], atol=5e-4, err_msg=f"step {k}")
        np.testing.assert_allclose(gpu.speed, cpu.speed, atol=5e-3, err_msg=f"step {k}")
        speeds.append(gpu.speed.copy())
        if k == 6:
            for batch in batches:
                batch.reset(options={"reset_mask": np.array([True, False])})
    assert np.array(speeds)[:, 1].max() > 2.0  # the cars did drive
    assert speeds[7][0] < 0.1 < 1.0 < speeds[6][0]  # world 0 restarted from rest
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
