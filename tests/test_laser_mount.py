"""LaserMount (the ray origin and axes from the chassis pose in qpos) against MuJoCo's kinematics of the laser's
site."""

from __future__ import annotations

import mujoco
import numpy as np

from racecar_sim.runtime import Simulator


def test_mount_gives_the_site_pose_mujoco_computes_at_any_car_pose():
    sim = Simulator(world="empty", camera=False)
    lidar = sim.car.lidar
    mount = lidar.mount
    assert mount is not None  # the Hokuyo sits on the chassis, the car's free body
    rng = np.random.default_rng(0)
    model, data = sim.model, mujoco.MjData(sim.model)
    rows = []
    for _ in range(20):
        data.qpos[:] = sim.data.qpos
        data.qpos[mount.qpos_adr : mount.qpos_adr + 3] = rng.uniform(-20, 20, 3)
        q = rng.normal(size=4)
        data.qpos[mount.qpos_adr + 3 : mount.qpos_adr + 7] = q / np.linalg.norm(q)
        mujoco.mj_kinematics(model, data)
        site = data.site_xmat[lidar._site].reshape(3, 3)
        expected_origin = data.site_xpos[lidar._site] + site @ lidar._offset
        expected_axes = site @ lidar._turn
        origin, axes = mount.pose(data.qpos)
        np.testing.assert_allclose(origin, expected_origin, rtol=0, atol=1e-12)
        np.testing.assert_allclose(axes, expected_axes, rtol=0, atol=1e-12)
        rows.append(data.qpos.copy())
    origins, axes_all = mount.poses(np.array(rows))
    for k, qpos in enumerate(rows):  # the batch's poses are the single car's, bit for bit
        origin, axes = mount.pose(qpos)
        np.testing.assert_array_equal(origins[k], origin)
        np.testing.assert_array_equal(axes_all[k], axes)
