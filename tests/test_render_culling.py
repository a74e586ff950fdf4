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
    model = mujoco.MjModel.from_xml_string(
        "<mujoco><worldbody>"
        + "".join(
            f"<geom type='box' size='{0.1 * (i + 1)} 0.2 0.3' pos='{i} {2 * i} 1' euler='{10 * i} {5 * i} {-20 * i}'/>"
            for i in range(5)
        )
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
        assert culler._type[i] == scene.geoms[i].type == mujoco.mjtGeom.mjGEOM_BOX
        assert np.array_equal(culler._half[i], scene.geoms[i].size)
        assert np.array_equal(culler._half[i], model.geom_size[i].astype(np.float32))
        assert np.array_equal(culler._mat[i], scene.geoms[i].mat.ravel())
        assert np.allclose(culler._mat[i], data.geom_xmat[i], atol=1e-6)


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


@pytest.mark.parametrize(("z", "kept"), [(-1.5, 0), (-1.1, 1)])
def test_a_box_whose_sphere_meets_the_frustum_is_left_out_only_when_the_box_lies_outside(z, kept):
    """A 1 m rod along the view, 1.5-2.5 m ahead of a level camera with a 45 degree view, under it: its bounding
    sphere (radius 0.5 m) reaches the widened frustum at either height, its box only at z = -1.1 m (the frustum's
    widened bottom plane is 0.52 m down a metre ahead: 1.04 m down at the rod's near end and 1.30 m at its far one)."""
    model = mujoco.MjModel.from_xml_string(
        f"<mujoco><worldbody><geom type='box' size='0.5 0.01 0.01' pos='1 0 {z}'/></worldbody></mujoco>"
    )
    scene, culler = _level_view(model)
    assert scene.camera[0].frustum_top == pytest.approx(scene.camera[0].frustum_near * np.tan(np.radians(22.5)))
    assert culler.cull() == 1 - kept and scene.ngeom == kept


def test_a_geom_wholly_before_the_near_plane_is_left_out():
    """The near plane 0.5 m ahead of the camera: a 5 cm ball 0.3 m ahead, inside the four side planes, has no pixel."""
    model = mujoco.MjModel.from_xml_string(
        "<mujoco><statistic extent='1'/><visual><map znear='0.5'/></visual><worldbody>"
        "<geom type='sphere' size='0.05' pos='-0.7 0 0'/><geom size='0.05' pos='1 0 0'/></worldbody></mujoco>"
    )
    scene, culler = _level_view(model)
    assert scene.camera[0].frustum_near == pytest.approx(0.5)
    assert culler.cull() == 1 and scene.ngeom == 1
    assert scene.geoms[0].pos[0] == pytest.approx(1.0)


def _level_view(model: mujoco.MjModel) -> tuple[mujoco.MjvScene, FrustumCuller]:
    """The scene of `model` at rest seen by a level camera at (-1, 0, 0) looking along +x, and its culler (64x48)."""
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    scene = mujoco.MjvScene(model, 10)
    culler = FrustumCuller(scene, 64, 48)
    camera = mujoco.MjvCamera()
    camera.lookat[:] = (0, 0, 0)
    camera.distance, camera.elevation, camera.azimuth = 1.0, 0.0, 0.0
    mujoco.mjv_updateScene(model, data, mujoco.MjvOption(), None, camera, mujoco.mjtCatBit.mjCAT_ALL, scene)
    return scene, culler
