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


def test_a_fleets_mounts_and_casters_read_what_each_car_alone_would():
    """A fleet's lasers share one pose of the model at qpos0 (made once) and find their car's bodies and the static
    geoms with array operations: each mount is what a fresh MjData's kinematics gives, bit for bit, each car's bodies
    are the subtree MuJoCo's parent table gives, and the static geoms are those welded to the world."""
    from racecar_sim import Car, Spawn
    from racecar_sim.sensors.laser_mount import LaserMount
    from racecar_sim.sensors.raycast.scene import is_static, static_geoms, subtree_bodies

    cars = [Car(f"car{k + 1}", spawn=Spawn(1.5 * k, 0.0, 0.05, 0.0), camera=False) for k in range(3)]
    sim = Simulator(world="tunnel", cars=cars)
    model = sim.model
    fresh = mujoco.MjData(model)
    mujoco.mj_kinematics(model, fresh)
    for car in sim.cars:
        lidar = car.lidar
        body = int(model.body_weldid[model.site_bodyid[lidar._site]])
        body_rot, site_rot = fresh.xmat[body].reshape(3, 3), fresh.site_xmat[lidar._site].reshape(3, 3)
        origin = body_rot.T @ (fresh.site_xpos[lidar._site] + site_rot @ lidar._offset - fresh.xpos[body])
        assert lidar.mount.local_origin.tobytes() == origin.tobytes()
        assert lidar.mount.local_axes.tobytes() == (body_rot.T @ (site_rot @ lidar._turn)).tobytes()
        assert LaserMount.of(model, lidar._site, lidar._offset, lidar._turn).local_origin.tobytes() == origin.tobytes()
        root = model.body(car.names.mj(car.robot.root)).id
        inside = {root}
        for b in range(root + 1, model.nbody):
            if int(model.body_parentid[b]) in inside:
                inside.add(b)
        assert subtree_bodies(model, root).tolist() == sorted(inside)
    assert subtree_bodies(model, 0).tolist() == list(range(model.nbody))  # the world: every body, the loop's way
    geoms = np.arange(model.ngeom)
    static = static_geoms(model, geoms).tolist()
    assert static == [is_static(model, int(g)) for g in geoms]
    assert any(static) and not all(static)  # the tunnel's walls and the cars
