"""The Hokuyo: LaserScan fields and timing as racecar.gazebo says, ranges equal to the geometry, the fast
caster equal to MuJoCo's 3-D ray casts, no self-hits, dynamic bodies seen, seeded noise."""

from __future__ import annotations

import inspect
import math
import xml.etree.ElementTree as ET

import mujoco
import numpy as np
import pytest
import trimesh

from racecar_sim import Simulator
from racecar_sim.core.errors import DescriptionError
from racecar_sim.core.transforms import compose, quat_from_rpy, yaw_of
from racecar_sim.description import load_robot
from racecar_sim.description.kinematics import link_pose
from racecar_sim.description.urdf import Origin, Sensor
from racecar_sim.physics import COLLISION_GROUP, ROOT_JOINT
from racecar_sim.sensors.laser_spec import LaserSpec
from racecar_sim.worlds import Mesh, Spawn, World, WorldBody, WorldGeom, load_world

SAMPLES, ANGLE_MIN, INCREMENT, SIGMA = 1081, -2.3561944902, 0.0043633231, 0.01
PILLAR = (1.5, 1.2, 0.25)  # x, y, radius of the room's pillar


def lidar_sim(noise: bool = True, **kwargs) -> Simulator:
    """A Simulator with the lidar on (its own, once the Simulator builds one) and the camera off."""
    params = inspect.signature(Simulator).parameters
    if "camera" in params:
        kwargs.setdefault("camera", False)
    if "sensor_noise" in params:
        kwargs["sensor_noise"] = noise
    return Simulator(**kwargs)


def scans_of(sim: Simulator, until: float) -> list:
    scans: list = []
    sim.subscribe("/scan", scans.append)
    sim.run_until(until)
    return scans


def _box(name: str, x: float, y: float, sx: float, sy: float) -> str:
    geometry = f"<geometry><box><size>{sx} {sy} 1</size></box></geometry>"
    return f"<link name='{name}'><pose>{x} {y} 0.5 0 0 0</pose><collision name='c'>{geometry}</collision></link>"


def room_world(tmp_path, half: float, pillar: bool = True, wall: float = 0.2) -> str:
    """An SDF box room of inner half-side `half` (m) centred on the origin, walls 1 m tall, and a pillar."""
    span, c = 2 * half + 2 * wall, half + wall / 2
    walls = (
        _box("north", 0, c, span, wall)
        + _box("south", 0, -c, span, wall)
        + _box("east", c, 0, wall, span)
        + _box("west", -c, 0, wall, span)
    )
    x, y, r = PILLAR
    column = (
        (
            f"<model name='pillar'><static>true</static><pose>{x} {y} 0.5 0 0 0</pose><link name='l'>"
            f"<collision name='c'><geometry><cylinder><radius>{r}</radius><length>1</length></cylinder>"
            f"</geometry></collision></link></model>"
        )
        if pillar
        else ""
    )
    path = tmp_path / "room.world"
    path.write_text(
        f"<?xml version='1.0'?><sdf version='1.6'><world name='room'>"
        f"<include><uri>model://ground_plane</uri></include>"
        f"<model name='room'><static>true</static>{walls}</model>{column}</world></sdf>"
    )
    return str(path)


def laser_origin_from_tf(sim: Simulator) -> tuple[np.ndarray, float]:
    """The ray origin in the world and its heading, from the URDF chain and the sensor <pose> (not the caster)."""
    laser_pos, laser_quat = link_pose(sim.car.robot, sim.car.robot.sensor("ray").link)
    sensor = sim.car.robot.sensor("ray").pose
    pos, quat = compose(laser_pos, laser_quat, np.array(sensor.xyz), quat_from_rpy(sensor.rpy))
    base_pos, base_quat = sim.car.state.base_pose()
    world_pos, world_quat = compose(base_pos, base_quat, pos, quat)
    return world_pos, yaw_of(world_quat)


def beam_angles(heading: float) -> np.ndarray:
    """World headings of the 1081 beams."""
    return heading + ANGLE_MIN + INCREMENT * np.arange(SAMPLES)


def room_ranges(origin: np.ndarray, angles: np.ndarray, half: float, pillar: bool = True) -> np.ndarray:
    """Geometric range along each heading in the room: the inner wall faces and the pillar's circle."""
    dx, dy = np.cos(angles), np.sin(angles)
    x0, y0 = origin[:2]
    with np.errstate(divide="ignore"):
        walls = np.minimum(
            np.where(dx > 0, (half - x0) / dx, np.where(dx < 0, (-half - x0) / dx, np.inf)),
            np.where(dy > 0, (half - y0) / dy, np.where(dy < 0, (-half - y0) / dy, np.inf)),
        )
    if not pillar:
        return walls
    cx, cy, r = PILLAR
    b = dx * (cx - x0) + dy * (cy - y0)
    disc = b * b - ((cx - x0) ** 2 + (cy - y0) ** 2 - r * r)
    column = np.where(disc >= 0, b - np.sqrt(np.maximum(disc, 0)), np.inf)
    return np.minimum(walls, np.where(column > 0, column, np.inf))


# --- the message ----------------------------------------------------------------------------------------------
def test_scan_fields_are_the_sensor_block_numbers():
    scan = scans_of(lidar_sim(world="empty"), 0.05)[-1]
    assert scan.angle_min == pytest.approx(-2.3561944902, abs=1e-12)
    assert scan.angle_max == pytest.approx(2.3561944902, abs=1e-12)
    assert scan.angle_increment == pytest.approx(INCREMENT, abs=1e-9)
    assert (scan.range_min, scan.range_max, scan.time_increment, scan.scan_time) == (0.1, 10.0, 0.0, 0.0)
    assert scan.header.frame_id == "laser"
    assert scan.ranges.dtype == np.float32 and scan.ranges.shape == (SAMPLES,)
    assert scan.intensities.dtype == np.float32 and not scan.intensities.any() and len(scan.intensities) == SAMPLES


def test_forty_hertz_exactly():
    scans = scans_of(lidar_sim(world="empty"), 10.0)
    stamps = [s.header.stamp.to_ns() for s in scans]
    assert len(scans) == 400
    assert stamps == [25_000_000 * k for k in range(1, 401)]


def test_scans_are_cast_only_for_listeners_and_noise_depends_only_on_the_stamp(tmp_path):
    world = room_world(tmp_path, 3.0)
    quiet = lidar_sim(world=world, seed=4)
    quiet.run_until(0.5)
    assert quiet.car.lidar.scans_cast == 0, "nobody listens: nothing is cast"
    late = scans_of(quiet, 1.0)
    always = scans_of(lidar_sim(world=world, seed=4), 1.0)
    assert len(late) == 20 and late[0].header.stamp.to_ns() == 525_000_000, "the schedule was kept"
    np.testing.assert_array_equal(late[-1].ranges, always[-1].ranges)


def test_a_scan_leaves_the_simulation_state_alone():
    sim = lidar_sim(world="tunnel")
    sim.run_until(0.2)
    before = (sim.data.qpos.copy(), sim.data.xpos.copy(), sim.data.geom_xpos.copy(), sim.model.geom_group.copy())
    sim.car.lidar.true_ranges()
    sim.car.lidar.caster.cast(*sim.car.lidar.ray_origin(), mode="3d")
    after = (sim.data.qpos, sim.data.xpos, sim.data.geom_xpos, sim.model.geom_group)
    assert all(np.array_equal(a, b) for a, b in zip(before, after))


# --- ranges against geometry -----------------------------------------------------------------------------------
@pytest.mark.parametrize("noise", [False, True])
def test_box_room_ranges_equal_the_geometry(tmp_path, noise):
    sim = lidar_sim(noise=noise, world=room_world(tmp_path, 3.0), seed=7)
    scan = scans_of(sim, 0.5)[-1]  # the car has landed after its 5 cm drop
    origin, heading = laser_origin_from_tf(sim)
    expected = room_ranges(origin, beam_angles(heading), 3.0)
    error = scan.ranges.astype(float) - expected
    assert np.all(np.isfinite(scan.ranges)) and expected.max() < 10
    if not noise:
        assert np.abs(error).max() < 1e-3
        return
    assert np.abs(error).max() < 5 * SIGMA, "no reading is further than 5 sigma off"
    assert np.mean(np.abs(error) < 3 * SIGMA) > 0.99, "99.7% within 3 sigma, as a Gaussian"
    assert abs(error.mean()) < 3 * SIGMA / math.sqrt(SAMPLES) and error.std() == pytest.approx(SIGMA, rel=0.1)


def test_a_room_larger_than_range_max_reads_inf_beyond_ten_metres(tmp_path):
    sim = lidar_sim(noise=False, world=room_world(tmp_path, 12.0, pillar=False), spawn=Spawn(4.0, 1.0, 0.05, 0.3))
    scan = scans_of(sim, 0.5)[-1]
    origin, heading = laser_origin_from_tf(sim)
    expected = room_ranges(origin, beam_angles(heading), 12.0, pillar=False)
    far = expected > 10.0 + 1e-3
    near = expected < 10.0 - 1e-3
    assert far.sum() > 300 and near.sum() > 100
    assert np.all(np.isinf(scan.ranges[far]))
    assert np.abs(scan.ranges[near] - expected[near]).max() < 1e-3


def test_objects_nearer_than_range_min_are_not_seen(tmp_path):
    """The laser 5 cm from a 0.2 m wall: rays start 0.1 m out, inside the wall, and see its far face."""
    sim = lidar_sim(noise=False, world=room_world(tmp_path, 3.0, pillar=False))
    laser_x = laser_origin_from_tf(sim)[0][0]
    sim.data.qpos[sim.model.jnt_qposadr[sim.model.joint(ROOT_JOINT).id]] += 3.0 - 0.05 - laser_x
    ranges = sim.car.lidar.true_ranges()
    assert ranges[SAMPLES // 2] == pytest.approx(0.05 + 0.2, abs=1e-6)


# --- the fast caster against MuJoCo's 3-D casts ----------------------------------------------------------------
def _place(sim: Simulator, x: float, y: float, z: float, rpy: tuple[float, float, float]) -> None:
    adr = sim.model.jnt_qposadr[sim.model.joint(ROOT_JOINT).id]
    sim.data.qpos[adr : adr + 3] = (x, y, z)
    sim.data.qpos[adr + 3 : adr + 7] = quat_from_rpy(rpy)


def _same(a: np.ndarray, b: np.ndarray) -> float:
    """Largest difference between two range arrays (inf equal to inf)."""
    with np.errstate(invalid="ignore"):  # inf - inf
        return float(np.max(np.where(np.isinf(a) & np.isinf(b), 0.0, np.abs(a - b))))


@pytest.mark.parametrize(
    "world,box", [("tunnel", ((-33, -3), (20, 42))), ("walker", ((-20, -12), (8, 14))), ("cones", ((-1, -2), (7, 2)))]
)
def test_fast_caster_equals_mujoco_3d_casts(world, box):
    sim = lidar_sim(world=world)
    rng = np.random.default_rng(11)
    if world == "cones":  # knock the cones about, and the last one over
        for i in range(1, 6):
            adr = sim.model.jnt_qposadr[sim.model.joint(f"cone_{i}::link::free").id]
            sim.data.qpos[adr : adr + 2] += rng.normal(0, 0.3, 2)
            if i == 5:
                sim.data.qpos[adr + 3 : adr + 7] = quat_from_rpy((1.4, 0.0, 0.5))
    fast_beams = 0
    for k in range(60):
        tilt = (0.0, 1e-4, 0.02)[k % 3]  # level; suspension sway; a slope that brings the floor into reach
        _place(
            sim,
            *rng.uniform(*box),
            rng.uniform(-0.15, 0.1),
            (rng.normal(0, tilt), rng.normal(0, tilt), rng.uniform(-math.pi, math.pi)),
        )
        fast = sim.car.lidar.true_ranges()
        fast_beams += sim.car.lidar.fan.count - sim.car.lidar.caster.last_3d_beams
        reference = sim.car.lidar.caster.cast(*sim.car.lidar.ray_origin(), mode="3d")
        assert _same(fast, reference) < 1e-3, f"pose {k}"
    assert fast_beams > 20 * SAMPLES, "most beams took the 2-D path"


def test_a_lone_car_in_an_empty_world_casts_only_the_scans_that_can_reach_the_floor(monkeypatch):
    """Level enough, a lone car's scan in `empty` can hit nothing (every beam stays above the ground plane within
    range_max): it is published as all inf without a cast. Pitched or rolled so that the ground is within reach, it
    is cast. Either way the published scan is MuJoCo's 3-D cast under Gazebo's rule, to the bit."""
    sim = lidar_sim(world="empty", noise=False)
    lidar = sim.car.lidar
    assert lidar.caster.floors_only == (0.0,)
    casts: list[int] = []
    cast = lidar.caster.cast
    monkeypatch.setattr(lidar.caster, "cast", lambda *a, **k: casts.append(1) or cast(*a, **k))
    rng = np.random.default_rng(3)
    cast_poses = hits = 0
    for k in range(40):
        tilt = (0.0, 1e-3, 0.05, 0.3)[k % 4]  # level, sway, a tilt that reaches the ground within 10 m, a steep one
        _place(sim, *rng.uniform(-5, 5, 2), rng.uniform(0.0, 0.1), (rng.normal(0, tilt), rng.normal(0, tilt), 0.3 * k))
        before = len(casts)
        published = lidar.scan(k * 25_000_000)
        reference = cast(*lidar.ray_origin(), mode="3d")
        hit = np.isfinite(reference)
        expected = np.where(hit, np.clip(reference, lidar.spec.range_min, lidar.spec.range_max), np.inf)
        np.testing.assert_array_equal(published, expected.astype(np.float32), err_msg=f"pose {k}")
        if tilt <= 1e-3:  # nothing within reach: no cast
            assert len(casts) == before and not hit.any(), f"pose {k}"
        cast_poses += len(casts) > before
        hits += bool(hit.any())
    assert cast_poses >= 10 and hits >= 10, "the steep poses (ground within reach) were cast, and saw the ground"


def test_a_tilted_scan_of_walls_stays_two_dimensional_and_exact():
    """Rolled and pitched by ~0.6 degrees the beams climb or dip up to 13 cm over 10 m - still inside the
    tunnel's 2.5 m walls and above the floor, so every beam takes the 2-D path, exact to float precision."""
    sim = lidar_sim(world="tunnel")
    rng = np.random.default_rng(5)
    for _ in range(10):
        _place(sim, rng.uniform(-25, -5), rng.uniform(-2, 0.5), 0.0, (0.01, -0.008, rng.uniform(-math.pi, math.pi)))
        fast = sim.car.lidar.true_ranges()
        assert sim.car.lidar.caster.last_3d_beams == 0
        assert _same(fast, sim.car.lidar.caster.cast(*sim.car.lidar.ray_origin(), mode="3d")) < 1e-9


def _geom(
    name: str, kind: str, size: tuple, pos: tuple, rpy: tuple = (0.0, 0.0, 0.0), mesh: Mesh | None = None
) -> WorldGeom:
    return WorldGeom(name, kind, size, np.array(pos, float), quat_from_rpy(rpy), mesh=mesh)


def _l_prism(height: float) -> Mesh:
    """A non-convex L-shaped block, extruded: MuJoCo ray-casts its triangles, not its convex hull."""
    outline = [(0, 0), (1, 0), (1, 0.4), (0.4, 0.4), (0.4, 1), (0, 1)]
    n = len(outline)
    vertices = [(x, y, 0.0) for x, y in outline] + [(x, y, height) for x, y in outline]
    faces = [f for i in range(n) for f in ((i, (i + 1) % n, n + (i + 1) % n), (i, n + (i + 1) % n, n + i))]
    cap = [(0, 1, 2), (0, 2, 3), (0, 3, 4), (0, 4, 5)]
    faces += [f[::-1] for f in cap] + [tuple(n + k for k in f) for f in cap]
    return Mesh(np.array(vertices, float), np.array(faces, np.int32))


def zoo_world(rng: np.random.Generator) -> World:
    """Every kind of geom around a 16 m room: pillars, spheres, capsules, tilted boxes and cylinders, an
    L-shaped mesh (a prism), cone meshes (not prisms), low boxes the scan grazes, and free bodies."""
    cone = trimesh.creation.cone(0.3, 0.6)
    kinds = [
        ("cylinder", (0.3, 1.0), 0.5, (0, 0, 0), None),
        ("sphere", (0.25,), 0.15, (0, 0, 0), None),
        ("capsule", (0.1, 0.5), 0.3, (0, 0, 0), None),
        ("box", (0.5, 0.3, 0.6), 0.2, (0.3, 0.1, 1.0), None),
        ("cylinder", (0.2, 0.6), 0.2, (0.4, 0, 0), None),
        ("mesh", (), 0.0, (0, 0, 0.7), _l_prism(0.8)),
        ("mesh", (), 0.0, (0, 0, 0), Mesh(np.asarray(cone.vertices, float), np.asarray(cone.faces, np.int32))),
        ("box", (0.6, 0.6, 0.13), 0.065, (0, 0, 0.4), None),
        ("ellipsoid", (0.2, 0.3, 0.25), 0.2, (0, 0, 0), None),
    ]
    geoms = [
        _geom(f"wall{i}", "box", size, (x, y, 0.5))
        for i, (x, y, size) in enumerate(
            [(0, 8, (16, 0.2, 1)), (0, -8, (16, 0.2, 1)), (8, 0, (0.2, 16, 1)), (-8, 0, (0.2, 16, 1))]
        )
    ]
    for i in range(36):
        kind, size, z, rpy, mesh = kinds[i % len(kinds)]
        geoms.append(_geom(f"{kind}{i}", kind, size, (*rng.uniform(-7, 7, 2), z), rpy, mesh))
    world = load_world("empty")
    world.bodies.append(WorldBody("zoo", np.zeros(3), np.array([1.0, 0, 0, 0]), geoms=geoms))
    for i, (kind, size) in enumerate([("box", (0.3, 0.2, 0.5)), ("cylinder", (0.15, 0.5)), ("sphere", (0.2,))] * 2):
        world.bodies.append(
            WorldBody(
                f"free{i}",
                np.array([*rng.uniform(-7, 7, 2), 0.3]),
                quat_from_rpy((0, 0, rng.uniform(0, 3))),
                static=False,
                geoms=[_geom(f"free{i}", kind, size, (0, 0, 0))],
            )
        )
    return world


def test_fast_caster_equals_mujoco_3d_casts_for_every_kind_of_geom():
    rng = np.random.default_rng(3)
    sim = lidar_sim(world=zoo_world(rng))
    for k in range(60):
        tilt = (0.0, 1e-4, 0.003)[k % 3]
        _place(
            sim,
            *rng.uniform(-8, 8, 2),
            rng.uniform(-0.1, 0.2),
            (rng.normal(0, tilt), rng.normal(0, tilt), rng.uniform(-math.pi, math.pi)),
        )
        fast = sim.car.lidar.true_ranges()
        assert _same(fast, sim.car.lidar.caster.cast(*sim.car.lidar.ray_origin(), mode="3d")) < 1e-3, f"pose {k}"


def test_car_never_sees_itself():
    sim = lidar_sim(world="empty")
    assert np.all(np.isinf(scans_of(sim, 1.0)[-1].ranges))
    _place(sim, 0.0, 0.0, 20.0, (1.0, 0.3, 0.0))  # rolled 57 degrees, far above the floor: beams pass the wheels
    assert np.all(np.isinf(sim.car.lidar.true_ranges()))
    origin, rotation = sim.car.lidar.ray_origin()
    assert np.all(np.isinf(sim.car.lidar.caster.cast(origin, rotation, mode="3d")))
    groups = np.zeros(6, np.uint8)
    groups[COLLISION_GROUP] = 1
    mujoco.mj_kinematics(sim.model, sim.data)
    hit = [
        mujoco.mj_ray(sim.model, sim.data, origin + 0.1 * d, d, groups, 1, -1, np.zeros(1, np.int32))
        for d in (rotation[:, :2] @ sim.car.lidar.fan.directions).T
    ]
    assert max(hit) > 0, "without the exclusion some of these beams would hit the car"


def test_pushable_cone_is_seen_where_it_is():
    sim = lidar_sim(noise=False, world="cones")
    sim.run_until(0.5)
    origin, heading = laser_origin_from_tf(sim)
    ahead = sim.car.lidar.true_ranges()[SAMPLES // 2]
    cone = sim.model.body("cone_1::link").id
    assert ahead == pytest.approx(sim.data.xpos[cone][0] - origin[0] - _cone_radius(origin[2]), abs=1e-3)
    adr = sim.model.jnt_qposadr[sim.model.joint("cone_1::link::free").id]
    sim.data.qpos[adr : adr + 2] = (origin[0] + 0.6, origin[1] + 0.4)  # pushed aside
    sim.run_for(0.1)
    origin, heading = laser_origin_from_tf(sim)
    offset = sim.data.xpos[cone][:2] - origin[:2]
    beam = round((math.atan2(offset[1], offset[0]) - heading - ANGLE_MIN) / INCREMENT)
    expected = np.hypot(*offset) - _cone_radius(origin[2])
    assert sim.car.lidar.true_ranges()[beam] == pytest.approx(expected, abs=2e-3)


def _cone_radius(z: float) -> float:
    """The cone mesh's radius at height z: 0.06 m at 5 mm, 0.012 m at 0.17 m (models/cone)."""
    return 0.06 + (z - 0.005) * (0.012 - 0.06) / (0.17 - 0.005)


# --- the sensor block is the source of truth -------------------------------------------------------------------
def _sensor(xml: str) -> Sensor:
    return Sensor("hokuyo_sensor", "ray", "laser", Origin((0.0, 0.0, 0.0124)), 40.0, ET.fromstring(xml))


def _block(robot_sensor: Sensor) -> str:
    return ET.tostring(robot_sensor.element, encoding="unicode")


def test_spec_reads_every_field():
    spec = LaserSpec.from_sensor(load_robot().sensor("ray"))
    assert (spec.samples, spec.min_angle, spec.max_angle) == (1081, -2.3561944902, 2.3561944902)
    assert (spec.range_min, spec.range_max, spec.update_rate) == (0.1, 10.0, 40.0)
    assert (spec.noise_type, spec.noise_mean, spec.noise_stddev) == ("gaussian", 0.0, 0.01)
    assert spec.pose.xyz == (0.0, 0.0, 0.0124) and (spec.link, spec.frame_id, spec.topic) == ("laser", "laser", "/scan")
    edited = _block(load_robot().sensor("ray")).replace("<samples>1081</samples>", "<samples>541</samples>")
    edited = edited.replace("<stddev>0.01</stddev>", "<stddev>0.03</stddev><type>gaussian</type>")
    spec = LaserSpec.from_sensor(_sensor(edited.replace("<max>10.0</max>", "<max>30</max>")))
    assert (spec.samples, spec.range_max, spec.noise_stddev) == (541, 30.0, 0.03)
    assert spec.angle_increment == pytest.approx(2 * 2.3561944902 / 540)


@pytest.mark.parametrize(
    "old,new,field",
    [
        ("<samples>1081</samples>", "", "samples"),
        ("<samples>1081</samples>", "<samples>many</samples>", "samples"),
        ("<min_angle>-2.3561944902</min_angle>", "", "min_angle"),
        ("<max>10.0</max>", "<max>ten</max>", "max"),
        ("<min>0.1</min>", "", "min"),
        ("<update_rate>40</update_rate>", "", "update_rate"),
        ("<stddev>0.01</stddev>", "<stddev>0.01</stddev><type>uniform</type>", "type"),
        ("<max>10.0</max>", "<max>0.05</max>", "range"),
        ("<resolution>1</resolution>", "<resolution>2</resolution>", "resolution"),
    ],
)
def test_a_missing_or_bad_field_is_named(old, new, field):
    block = _block(load_robot().sensor("ray"))
    assert old in block
    with pytest.raises(DescriptionError, match=field):
        LaserSpec.from_sensor(_sensor(block.replace(old, new, 1)))


def test_an_edited_description_changes_the_scan(tmp_path):
    robot = load_robot()
    urdf = (
        robot.urdf.replace("<samples>1081</samples>", "<samples>361</samples>")
        .replace("<min_angle>-2.3561944902</min_angle>", "<min_angle>-1.5707963268</min_angle>")
        .replace("<max_angle>2.3561944902</max_angle>", "<max_angle>1.5707963268</max_angle>")
        .replace("<pose>0 0 0.0124 0 0 0</pose>", "<pose>0 0 0.0124 0 0 0.5</pose>")
        .replace("<update_rate>40</update_rate>", "<update_rate>10</update_rate>")
    )
    path = tmp_path / "racecar.urdf"
    path.write_text(urdf)
    sim = lidar_sim(noise=False, world=room_world(tmp_path, 3.0, pillar=False), xacro=path)
    scans = scans_of(sim, 1.0)
    assert len(scans) == 10 and len(scans[-1].ranges) == 361
    assert scans[-1].angle_min == pytest.approx(-math.pi / 2)
    assert scans[-1].angle_increment == pytest.approx(math.pi / 360)
    origin, heading = laser_origin_from_tf(sim)  # includes the sensor pose's 0.5 rad yaw
    angles = heading - math.pi / 2 + math.pi / 360 * np.arange(361)
    assert np.abs(scans[-1].ranges - room_ranges(origin, angles, 3.0, pillar=False)).max() < 1e-3


def test_disable_gazebo_laser_removes_the_sensor(monkeypatch):
    monkeypatch.setenv("DISABLE_GAZEBO_LASER", "true")
    assert load_robot().sensor("ray") is None
    monkeypatch.setenv("DISABLE_GAZEBO_LASER", "false")
    assert load_robot().sensor("ray") is not None


# --- noise ----------------------------------------------------------------------------------------------------
def test_same_seed_same_scans_other_seed_other_noise(tmp_path):
    world = room_world(tmp_path, 3.0)
    a, b, c = (scans_of(lidar_sim(world=world, seed=s), 0.3)[-1].ranges for s in (5, 5, 6))
    np.testing.assert_array_equal(a, b)
    assert np.mean(a != c) > 0.9
    assert np.abs(a - c).max() < 10 * SIGMA


def test_compiled_laser_rule_is_the_numpy_rule_bit_for_bit():
    """LidarPublisher.publish (numba: noise, clamp, float32 in one pass; what a walled world's scans and the batch
    use) gives what the numpy rule (a world without walls) gives, for hits, misses, ranges the noise pushes past
    either limit, with and without noise."""
    from racecar_sim.runtime import Simulator

    sim = Simulator(world="empty", camera=False, lidar=True)
    lidar = sim.car.lidar
    rng = np.random.default_rng(5)
    true = rng.uniform(lidar.spec.range_min - 0.05, lidar.spec.range_max + 0.05, (6, lidar.spec.samples))
    true[rng.random(true.shape) < 0.3] = np.inf
    seeds, stamps = np.arange(6) * 7, np.arange(6) * 25_000_000
    for noise in (True, False):
        lidar.noise = noise
        compiled = lidar.publish(true.copy(), seeds, stamps)
        for i in range(6):
            ranges = true[i].copy()
            hit = np.isfinite(ranges)
            if noise:
                ranges += lidar.scan_noise(lidar.noise_table.sample(int(seeds[i]), int(stamps[i])))
            expected = np.where(hit, np.clip(ranges, lidar.spec.range_min, lidar.spec.range_max), np.inf)
            np.testing.assert_array_equal(compiled[i], expected.astype(np.float32))


@pytest.mark.parametrize("world", ["walker", "tunnel"])
def test_one_call_scan_is_the_step_by_step_scan_bit_for_bit(world):
    """LidarPublisher.scan's compiled whole-scan path (laser_kernel.level_scan: pose from qpos, grid cell, wall cast,
    noise) publishes what the step-by-step path (LaserMount, RayCaster.cast, the laser rule) publishes, at random
    poses of the car, level and pitched or rolled a little (which may send a scan to the general path)."""
    from racecar_sim.core.transforms import quat_from_rpy
    from racecar_sim.runtime import Simulator

    sim = Simulator(world=world, camera=False)
    lidar = sim.car.lidar
    assert lidar.caster.level_walls() is not None
    adr = lidar.mount.qpos_adr
    rng = np.random.default_rng(1)
    base = sim.data.qpos.copy()
    step_by_step = type(lidar.caster).level_walls
    calls = []
    true_ranges = lidar.true_ranges
    lidar.true_ranges = lambda: calls.append(1) or true_ranges()  # only the step-by-step path calls it
    one_call = 0
    for k in range(60):
        sim.data.qpos[:] = base
        sim.data.qpos[adr : adr + 2] += rng.uniform(-3, 3, 2)
        tilt = rng.normal(0, 0.02, 2) if k % 2 else (0.0, 0.0)
        sim.data.qpos[adr + 3 : adr + 7] = quat_from_rpy((*tilt, rng.uniform(-np.pi, np.pi)))
        calls.clear()
        fused = lidar.scan(k * 25_000_000)
        one_call += not calls
        lidar.caster.level_walls = lambda: None
        try:
            expected = lidar.scan(k * 25_000_000)
        finally:
            lidar.caster.level_walls = step_by_step.__get__(lidar.caster)
        np.testing.assert_array_equal(fused, expected)
    assert one_call >= 30  # the level scans at least took the one-call path


def test_the_one_call_scan_follows_a_noise_switch_and_a_car_spawned_at_run_time():
    """The one compiled call's arguments are kept from scan to scan: switching the noise off, and a car spawned at run
    time (a recompiled model: every lidar rebound), show in the very next scan, as in the step-by-step path."""
    from racecar_sim import Car, Spawn

    sim = Simulator(world="tunnel", cars=[Car("car1", spawn=Spawn(-31.0, -1.0, 0.05, 0.0), camera=False)])
    lidar = sim.car.lidar
    sim.run_until(0.5)

    def step_by_step(stamp: int) -> np.ndarray:
        walls_only = lidar.caster.level_walls
        lidar.caster.level_walls = lambda: None
        try:
            return lidar.scan(stamp)
        finally:
            lidar.caster.level_walls = walls_only

    noisy = lidar.scan(25_000_000)
    lidar.noise = False
    before = lidar.one_call_scans
    clean = lidar.scan(25_000_000)
    assert lidar.one_call_scans == before + 1
    np.testing.assert_array_equal(clean, step_by_step(25_000_000))
    hit = np.isfinite(clean)
    assert np.mean(clean[hit] != noisy[hit]) > 0.9  # the switch took: no noise now
    ahead = Car("car2", spawn=Spawn(-29.5, -1.0, 0.05, 0.0), camera=False)
    ahead.load()
    sim.spawn_car(ahead)
    before = lidar.one_call_scans
    seen = lidar.scan(50_000_000)
    assert lidar.one_call_scans == before + 1
    expected = step_by_step(50_000_000)
    assert np.array_equal(np.isinf(seen), np.isinf(expected))
    finite = np.isfinite(expected)
    np.testing.assert_allclose(seen[finite], expected[finite], rtol=0, atol=1e-5)
    assert np.min(seen[finite]) < 1.5  # the car spawned 1.5 m ahead is in the scan


@pytest.mark.parametrize("world", ["walker", "tunnel"])
def test_a_fleet_scan_casts_the_other_cars_in_the_one_call_path_as_mujoco_does(world):
    """With other cars in the world each lidar's scan still takes the one compiled call (laser_kernel.level_scan:
    walls in 2-D, the other cars' boxes and wheels beam by beam with MuJoCo's formulas) and publishes what the
    step-by-step path publishes (RayCaster.cast: the other cars cast by mj_multiRay in 3-D), at random poses of three
    cars close together, level and pitched or rolled a little, and the other cars are in the scan."""
    from racecar_sim import Car, Spawn

    spawns = {"walker": (-18.0, -11.0), "tunnel": (-31.0, -1.0)}[world]
    x, y = spawns
    cars = [Car(f"car{k + 1}", spawn=Spawn(x + 1.5 * k, y, 0.05, 0.0), camera=False) for k in range(3)]
    sim = Simulator(world=world, cars=cars)
    rng = np.random.default_rng(3)
    base = sim.data.qpos.copy()
    one_call = seen = 0
    for k in range(40):
        sim.data.qpos[:] = base
        centre = sim.data.qpos[sim.cars[0].lidar.mount.qpos_adr : sim.cars[0].lidar.mount.qpos_adr + 2].copy()
        for car in sim.cars[1:]:  # the others within a few metres of the first, at any heading
            adr = car.lidar.mount.qpos_adr
            sim.data.qpos[adr : adr + 2] = centre + rng.uniform(-2.5, 2.5, 2)
        for car in sim.cars:
            adr = car.lidar.mount.qpos_adr
            tilt = rng.normal(0, 0.02, 2) if k % 2 else (0.0, 0.0)
            sim.data.qpos[adr + 3 : adr + 7] = quat_from_rpy((*tilt, rng.uniform(-np.pi, np.pi)))
        for car in sim.cars:
            lidar = car.lidar
            before = lidar.one_call_scans
            fused = lidar.scan(k * 25_000_000)
            one_call += lidar.one_call_scans - before
            walls_only = lidar.caster.level_walls
            lidar.caster.level_walls = lambda: None
            try:
                expected = lidar.scan(k * 25_000_000)
            finally:
                lidar.caster.level_walls = walls_only
            assert np.array_equal(np.isinf(fused), np.isinf(expected)), f"pose {k}, {car.name}"
            finite = np.isfinite(expected)
            np.testing.assert_allclose(fused[finite], expected[finite], rtol=0, atol=1e-5, err_msg=f"pose {k}")
            seen += lidar.caster.last_3d_beams > 0  # the general path met another car
    assert one_call >= 60, one_call  # level or a little tilted, the scans took the one compiled call
    assert seen >= 40, seen  # and the other cars were in them
