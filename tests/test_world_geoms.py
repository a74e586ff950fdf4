"""How a world's static geometry enters MuJoCo: placed once (sleeping on, every moving tree awake, so dynamics
are those of a model without it), visual boxes drawn as one mesh of the same faces, the ground plane on a
static body of its own."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

from racecar_sim import Simulator
from racecar_sim.core.transforms import quat_from_axis_angle, quat_to_matrix
from racecar_sim.drivers import ConstantCommand
from racecar_sim.physics.world_geoms import COLLISION_GROUP, VISUAL_GROUP, box_mesh
from racecar_sim.worlds import load_world
from racecar_sim.worlds.walls import box_geoms
from racecar_sim.worlds.world import WorldBody, WorldGeom


def walled_world(count: int = 12):
    """`empty` with a ring of `count` static wall boxes (collision + visual) 3 m around the origin."""
    world = load_world("empty")
    angles = np.linspace(0.0, 2 * math.pi, count, endpoint=False)
    centres = np.c_[3.0 * np.cos(angles), 3.0 * np.sin(angles), np.full(count, 0.5)]
    sizes = np.tile([0.3, 1.4, 1.0], (count, 1))
    world.bodies.append(
        WorldBody(
            "ring",
            np.array([0.5, -0.2, 0.0]),
            quat_from_axis_angle((0, 0, 1), 0.3),
            static=True,
            geoms=box_geoms("ring", centres, sizes, angles),
        )
    )
    return world


def drive(sim: Simulator, seconds: float, steer: float = 0.3) -> np.ndarray:
    ConstantCommand(sim.bus, sim.scheduler, 1.5, steer)
    sim.run_until(seconds)
    return np.r_[sim.data.qpos, sim.data.qvel]


@pytest.mark.parametrize("world", ["cones", "ring"])
def test_dynamics_are_bit_identical_with_sleeping_off(world):
    """The car pushes the cones (free bodies) or circles inside the ring of walls: the same state to the last bit."""
    states = []
    for sleep in (True, False):
        sim = Simulator(world=walled_world() if world == "ring" else world, lidar=False, camera=False)
        assert sim.model.opt.enableflags & mujoco.mjtEnableBit.mjENBL_SLEEP
        assert np.all(sim.model.tree_sleep_policy == mujoco.mjtSleepPolicy.mjSLEEP_NEVER)
        if not sleep:
            sim.model.opt.enableflags &= ~int(mujoco.mjtEnableBit.mjENBL_SLEEP)
        states.append(drive(sim, 4.0, steer=0.0 if world == "cones" else 0.3))
        assert np.all(sim.data.tree_asleep < 0)  # nothing ever slept
    assert states[0].tobytes() == states[1].tobytes()
    if world == "cones":  # the cones' free joints come first: a cone was pushed
        assert np.abs(states[0][:35] - sim.model.qpos0[:35]).max() > 0.1


def test_static_geoms_are_placed_by_reset_without_a_step():
    sim = Simulator(world=walled_world(), lidar=False, camera=False)
    ring = [g for g in range(sim.model.ngeom) if sim.model.geom(g).name.startswith("ring")]
    placed = sim.data.geom_xpos[ring].copy(), sim.data.geom_xmat[ring].copy()
    drive(sim, 1.0)
    sim.data.geom_xpos[ring] = 0.0  # not recomputed by a step ...
    mujoco.mj_step(sim.model, sim.data)
    assert np.all(sim.data.geom_xpos[ring] == 0.0)
    mujoco.mj_resetData(sim.model, sim.data)  # ... but by a reset, as by making the data
    np.testing.assert_array_equal(sim.data.geom_xpos[ring], placed[0])
    np.testing.assert_array_equal(sim.data.geom_xmat[ring], placed[1])


def test_visual_boxes_become_one_mesh_named_after_the_first():
    world = walled_world()
    sim = Simulator(world=world, lidar=False, camera=False)
    model = sim.model
    visual = [
        g for g in range(model.ngeom) if model.geom(g).name.startswith("ring") and model.geom_group[g] == VISUAL_GROUP
    ]
    collision = [
        g
        for g in range(model.ngeom)
        if model.geom(g).name.startswith("ring") and model.geom_group[g] == COLLISION_GROUP
    ]
    assert len(collision) == 12
    assert [model.geom(g).name for g in visual] == ["ring_0_visual"]
    assert model.geom_type[visual[0]] == mujoco.mjtGeom.mjGEOM_MESH
    assert model.geom_contype[visual[0]] == model.geom_conaffinity[visual[0]] == 0
    np.testing.assert_allclose(model.geom_rgba[visual[0]], world.bodies[-1].geoms[1].rgba)


def test_box_mesh_has_every_box_face_facing_out():
    rng = np.random.default_rng(3)
    boxes = [
        (
            WorldGeom("b", "box", tuple(rng.uniform(0.1, 2.0, 3)), np.zeros(3), np.array([1.0, 0, 0, 0])),
            rng.uniform(-5, 5, 3),
            quat_from_axis_angle(rng.normal(size=3), rng.uniform(0, math.pi)),
        )
        for _ in range(5)
    ]
    mesh = box_mesh(boxes)
    assert mesh.vertices.shape == (5 * 24, 3) and mesh.faces.shape == (5 * 12, 3)
    triangles = mesh.vertices[mesh.faces]
    normals = np.cross(triangles[:, 1] - triangles[:, 0], triangles[:, 2] - triangles[:, 0])
    for k, (geom, pos, quat) in enumerate(boxes):
        size = np.array(geom.size)
        local = (mesh.vertices[24 * k : 24 * (k + 1)] - pos) @ quat_to_matrix(quat)
        np.testing.assert_allclose(np.abs(local), np.tile(size / 2, (24, 1)), atol=1e-12)  # the box's corners
        n, t = normals[12 * k : 12 * (k + 1)], triangles[12 * k : 12 * (k + 1)]
        assert np.all(np.einsum("ij,ij->i", n, t.mean(axis=1) - pos) > 0)  # counter-clockwise seen from outside
        area = 0.5 * np.linalg.norm(n, axis=1).sum()
        assert area == pytest.approx(2 * (size[0] * size[1] + size[1] * size[2] + size[0] * size[2]))


def test_the_ground_plane_collides_from_a_static_body_of_its_own():
    """The world body's bounding-volume tree holds only finite walls; the plane is still welded to the world."""
    sim = Simulator(world=walled_world(), lidar=False, camera=False)
    model = sim.model
    (plane,) = [
        g for g in range(model.ngeom) if model.geom_type[g] == mujoco.mjtGeom.mjGEOM_PLANE and model.geom_contype[g]
    ]
    body = model.geom_bodyid[plane]
    assert body != 0 and model.body_weldid[body] == 0 and model.body_geomnum[body] == 1
    assert np.all(np.isfinite(model.bvh_aabb[model.body_bvhadr[0]]))
    assert np.all(model.bvh_aabb[model.body_bvhadr[0]][3:] < 10.0)
    start = sim.data.qpos[:3].copy()
    drive(sim, 1.0)
    assert np.hypot(*(sim.data.qpos[:2] - start[:2])) > 0.5  # it drives, on the ground: neither sinks nor falls
    assert abs(sim.data.qpos[2] - start[2]) < 0.06 and np.any(sim.data.contact.geom[: sim.data.ncon] == plane)
