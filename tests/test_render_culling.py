"""Frustum culling (render/culling.py): the geoms left out of a drawing are ones with no pixel in the image, so the
frames are MuJoCo's bit for bit; and it does leave geoms out (the car under the camera, the walls behind it)."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from conftest import needs_gl, random_car_poses
from racecar_sim import Simulator
from racecar_sim.render.culling import FrustumCuller, _record_layout


def test_the_geom_records_are_found_and_read_back_what_the_bindings_wrote():
    layout = _record_layout()
    assert layout is not None, "this MuJoCo's MjvGeom layout was not found: no culling"
    size, pos_at, rbound_at = layout
    model = mujoco.MjModel.from_xml_string(
        "<mujoco><worldbody>"
        + "".join(f"<geom type='box' size='{0.1 * (i + 1)} 0.2 0.3' pos='{i} {2 * i} 1'/>" for i in range(5))
        + "</worldbody></mujoco>"
    )
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    scene = mujoco.MjvScene(model, 20)
    mujoco.mjv_updateScene(model, data, mujoco.MjvOption(), None, mujoco.MjvCamera(), mujoco.mjtCatBit.mjCAT_ALL, scene)
    culler = FrustumCuller(scene, 640, 480)
    assert culler.active
    for i in range(scene.ngeom):
        assert np.array_equal(culler._pos[i], scene.geoms[i].pos)
        assert culler._rbound[i] == np.float32(scene.geoms[i].modelrbound)
        assert culler._rbound[i] == pytest.approx(model.geom_rbound[i], rel=1e-6)


@needs_gl
@pytest.mark.parametrize("world", ["walker", "tunnel"])
def test_culled_frames_are_mujocos_bit_for_bit_and_geoms_are_left_out(world):
    sim = Simulator(world=world, seed=3, lidar=False, camera=True, sensor_noise=False)
    camera = sim.car.camera
    renderer = camera.renderer
    dropped = []
    for k, _ in enumerate(random_car_poses(sim, 12, seed=11)):
        renderer.cull = True
        culled = camera.capture(1_000_000 * k)
        assert renderer.target is not None
        drawn = renderer.target.scene.ngeom
        renderer.cull = False
        full = camera.capture(1_000_000 * k)
        dropped.append(renderer.target.scene.ngeom - drawn)
        assert np.array_equal(culled, full), f"pose {k}: {(culled != full).any(axis=2).sum()} pixels differ"
    car_geoms = int((sim.model.geom_bodyid > 0).sum())
    assert min(dropped) > 0, f"no geom left out at some pose: {dropped}"
    assert np.mean(dropped) >= 0.25 * car_geoms, f"too few geoms left out: {dropped}"
    sim.close()


def test_an_orthographic_camera_or_an_empty_scene_keeps_everything():
    model = mujoco.MjModel.from_xml_string("<mujoco><worldbody><geom size='0.1' pos='0 0 -5'/></worldbody></mujoco>")
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    scene = mujoco.MjvScene(model, 10)
    culler = FrustumCuller(scene, 64, 48)
    assert culler.cull() == 0  # nothing posed yet
    camera = mujoco.MjvCamera()
    camera.lookat[:] = (0, 0, 0)
    camera.distance, camera.elevation, camera.azimuth = 1.0, 0.0, 0.0  # looking along +x, level
    option = mujoco.MjvOption()
    mujoco.mjv_updateScene(model, data, option, None, camera, mujoco.mjtCatBit.mjCAT_ALL, scene)
    assert culler.cull() == 1 and scene.ngeom == 0  # 5 m under a level camera with a 45 degree view: outside
    mujoco.mjv_updateScene(model, data, option, None, camera, mujoco.mjtCatBit.mjCAT_ALL, scene)
    scene.camera[0].orthographic = scene.camera[1].orthographic = 1
    assert culler.cull() == 0 and scene.ngeom == 1
