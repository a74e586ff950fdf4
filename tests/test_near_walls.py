"""A map's walls held out of MuJoCo's collision model (physics.near_walls) give the contacts, the drive, the scans
and the spawn check that the same walls as geoms give."""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
import pytest
from PIL import Image

from racecar_sim import Simulator
from racecar_sim.core.errors import WorldError
from racecar_sim.core.transforms import quat_from_axis_angle, quat_to_matrix
from racecar_sim.description import DEFAULT_XACRO, expand_xacro
from racecar_sim.drivers import ConstantCommand
from racecar_sim.msgs import Point, Pose, Quaternion
from racecar_sim.msgs.gazebo_msgs import DeleteModelRequest, SpawnModelRequest
from racecar_sim.physics.near_walls import MIN_BOXES, SLACK, WallBoxes
from racecar_sim.worlds import Spawn

RES, SIDE = 0.05, 8.0  # m per cell, m


def speckled_room(folder: Path, seed: int = 3) -> Path:
    """An 8 m room (one-cell walls, a 45-degree wall drawn in steps) with 400 single occupied cells strewn outside
    a clear circle around the spawn point (0, 0): many more boxes than MIN_BOXES, most of them tiny."""
    cells = round(SIDE / RES)
    occupied = np.zeros((cells, cells), bool)
    occupied[0], occupied[-1], occupied[:, 0], occupied[:, -1] = True, True, True, True
    steps = np.arange(30, 70)
    occupied[steps, steps + 60] = True
    rng = np.random.default_rng(seed)
    rows, cols = rng.integers(1, cells - 1, (2, 1200))
    centre = (cells - 1) / 2
    far = np.hypot(rows - centre, cols - centre) * RES > 1.3
    occupied[rows[far][:400], cols[far][:400]] = True
    Image.fromarray(np.where(occupied, 0, 254).astype(np.uint8)).save(folder / "speckle.pgm")
    path = folder / "speckle.yaml"
    path.write_text(
        f"image: speckle.pgm\nresolution: {RES}\norigin: [{-SIDE / 2}, {-SIDE / 2}, 0.0]\nnegate: 0\n"
        "occupied_thresh: 0.65\nfree_thresh: 0.196\n"
    )
    return path


@pytest.fixture(scope="module")
def room(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return speckled_room(tmp_path_factory.mktemp("near_walls"))


def pair(room: Path, **options: object) -> tuple[Simulator, Simulator]:
    """The same world with the walls held out (near) and as geoms (full)."""
    return (
        Simulator(world=str(room), camera=False, **options),
        Simulator(world=str(room), camera=False, near_walls=False, **options),
    )


def place(sim: Simulator, x: float, y: float, yaw: float) -> None:
    sim.car.state.set_base_pose(x, y, 0.05, yaw)
    mujoco.mj_forward(sim.model, sim.data)
    sim.poses_changed()
    mujoco.mj_forward(sim.model, sim.data)


def contacts(sim: Simulator) -> np.ndarray:
    """Every contact as (dist, position, normal), sorted: what the solver gets, whichever geom ids they have."""
    n = sim.data.ncon
    rows = np.hstack([sim.data.contact.dist[:n, None], sim.data.contact.pos[:n], sim.data.contact.frame[:n, :3]])
    return rows[np.lexsort(rows.T[::-1])]


def test_the_map_is_held_out_and_the_model_keeps_only_a_few_slots(room):
    near, full = pair(room)
    boxes = WallBoxes.of(near.model)
    assert boxes is not None and len(boxes) >= MIN_BOXES
    assert WallBoxes.of(full.model) is None
    colliding = (full.model.geom_contype != 0) | (full.model.geom_conaffinity != 0)
    assert colliding.sum() >= len(boxes)
    assert len(near.near_walls.geoms) < len(boxes) / 4
    assert near.model.ngeom < full.model.ngeom - len(boxes) / 2


def test_contacts_at_random_poses_against_walls_are_those_of_the_full_model(room):
    near, full = pair(room)
    boxes = WallBoxes.of(near.model)
    rng = np.random.default_rng(1)
    touching = 0
    for _ in range(40):
        box = rng.integers(len(boxes))
        angle = rng.uniform(-np.pi, np.pi)
        x, y = boxes.pos[box, :2] + rng.uniform(0.05, 0.3) * np.array([np.cos(angle), np.sin(angle)])
        yaw = rng.uniform(-np.pi, np.pi)
        for sim in (near, full):
            place(sim, x, y, yaw)
        expected = contacts(full)
        touching += len(expected) > 4  # more than the four wheels on the ground
        np.testing.assert_allclose(contacts(near), expected, rtol=0, atol=1e-12)
    assert touching >= 10


def test_every_box_within_reach_is_in_a_slot_wherever_the_car_is(room):
    near, _ = pair(room)
    walls, boxes = near.near_walls, WallBoxes.of(near.model)
    lower, upper = boxes.corners_xy()
    rng = np.random.default_rng(2)
    for _ in range(60):
        place(near, *rng.uniform(-SIDE / 2, SIDE / 2, 2), rng.uniform(-np.pi, np.pi))
        root = near.data.xpos[walls.roots[0], :2]
        gap = np.hypot(*np.maximum(np.maximum(lower - root, root - upper), 0.0).T)  # root to each box's bound
        within = np.flatnonzero(gap <= walls.reach[0] + SLACK)
        assert set(within.tolist()) <= set(walls.held.tolist())


def test_driving_into_the_walls_follows_the_full_model(room):
    near, full = pair(room)
    for sim in (near, full):
        ConstantCommand(sim.bus, sim.scheduler, speed=2.0, steering_angle=0.0)
        sim.run_for(4.0)
    # 2 m/s for 4 s would be over 7 m in the open: the speckle beyond the clear circle stops the car
    assert 0.7 < np.hypot(*full.data.qpos[:2]) < 2.0
    np.testing.assert_allclose(near.data.qpos, full.data.qpos, rtol=0, atol=1e-6)


def test_scans_see_the_held_out_walls_as_the_full_model_does(room):
    near, full = pair(room, sensor_noise=False)
    rng = np.random.default_rng(4)
    for _ in range(5):
        x, y, yaw = *rng.uniform(-1.0, 1.0, 2), rng.uniform(-np.pi, np.pi)
        for sim in (near, full):
            place(sim, x, y, yaw)
        ranges = [sim.car.lidar.scan(0) for sim in (near, full)]
        assert np.isfinite(ranges[1]).sum() > 500
        np.testing.assert_array_equal(ranges[0], ranges[1])
    origin = np.array([0.3, -0.2, 0.2])
    tilted = quat_to_matrix(quat_from_axis_angle((1.0, 0.3, 0.0), 0.6))  # a crash: the scan plane is steep
    np.testing.assert_allclose(
        near.car.lidar.caster.cast(origin, tilted), full.car.lidar.caster.cast(origin, tilted), rtol=0, atol=1e-12
    )


def test_a_spawn_inside_a_held_out_wall_is_refused(room):
    boxes = WallBoxes.of(Simulator(world=str(room), camera=False, lidar=False).model)
    x, y = boxes.pos[np.argmax(boxes.half[:, 0] * boxes.half[:, 1]), :2]  # inside the biggest box
    with pytest.raises(WorldError, match="inside"):
        Simulator(world=str(room), camera=False, lidar=False, spawn=Spawn(float(x), float(y), 0.05, 0.0))


def test_deleting_the_map_model_takes_its_held_out_walls_away(room):
    near, _ = pair(room, sensor_noise=False)
    place(near, 1.8, 1.8, 0.0)
    assert np.isfinite(near.car.lidar.scan(0)).any()
    name = next(m for m in near.gazebo.model_names if m not in ("racecar", "ground_plane"))
    assert near.gazebo.delete_model(DeleteModelRequest(name)).success
    assert WallBoxes.of(near.model) is None
    assert (near.near_walls.held < 0).all()
    place(near, 1.8, 1.8, 0.0)
    assert not np.isfinite(near.car.lidar.scan(0)).any()


def test_a_car_spawned_at_run_time_gets_slots_of_its_own(room):
    near, _ = pair(room, lidar=False)
    before = len(near.near_walls.geoms)
    urdf = expand_xacro(DEFAULT_XACRO, {})
    pose = Pose(Point(-0.8, 0.0, 0.05), Quaternion(0.0, 0.0, 0.0, 1.0))
    assert near.bus.call("/gazebo/spawn_urdf_model", SpawnModelRequest("car2", urdf, "car2", pose)).success
    walls = near.near_walls
    assert len(walls.roots) == 2 and len(walls.geoms) == 2 * before
    for car in near.cars:  # each car's neighbourhood is held, wherever it is
        car.state.set_base_pose(*np.random.default_rng(len(car.name)).uniform(-3.5, 3.5, 2), 0.05, 0.0)
    mujoco.mj_forward(near.model, near.data)
    near.poses_changed()
    lower, upper = WallBoxes.of(near.model).corners_xy()
    for mover, root in enumerate(walls.roots):
        xy = near.data.xpos[root, :2]
        gap = np.hypot(*np.maximum(np.maximum(lower - xy, xy - upper), 0.0).T)
        assert set(np.flatnonzero(gap <= walls.reach[mover] + SLACK).tolist()) <= set(walls.held.tolist())


def test_the_dense_scan_of_a_map_is_mujocos_own_ray_cast(room):
    """The map's cells are dense (raycast/dense.py casts them): the published scan, noise off, is MuJoCo's 3-D ray
    cast of the held-out walls, clamped and rounded to float32 as Gazebo publishes it."""
    near, _ = pair(room, sensor_noise=False)
    assert near.car.lidar.caster.level_walls().dense
    rng = np.random.default_rng(5)
    spec = near.car.lidar.spec
    for _ in range(4):
        place(near, *rng.uniform(-1.0, 1.0, 2), rng.uniform(-np.pi, np.pi))
        published = near.car.lidar.scan(0)
        assert near.car.lidar.caster.last_3d_beams == 0  # the compiled 2-D path answered
        rays = near.car.lidar.caster.cast(*near.car.lidar.ray_origin(), mode="3d")
        expected = np.where(np.isfinite(rays), np.clip(rays, spec.range_min, spec.range_max), np.inf)
        assert np.isfinite(expected).sum() > 500
        np.testing.assert_allclose(published, expected.astype(np.float32), rtol=0, atol=1e-5)
