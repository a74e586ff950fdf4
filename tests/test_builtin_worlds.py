"""Every built-in world loads, the car lands on its ground and drives; the tunnel matches the original wall table."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

from racecar_sim import Simulator
from racecar_sim.drivers import ConstantCommand
from racecar_sim.physics import COLLISION_GROUP
from racecar_sim.worlds import load_world, world_names

# Ground under the spawn point: the walker racecourse has no ground plane, its road is at z = -0.142 (§3.4).
GROUND_Z = {"walker": -0.142}

# MIT_Tunnel wall centre lines in the world, end A and end B, from original_stack.md §3.4 (0.15 m thick).
TUNNEL_WALLS = {
    "Wall_10": ((-29.541, 35.573), (3.151, 35.539)),
    "Wall_12": ((3.075, 35.614), (3.075, 27.114)),
    "Wall_15": ((3.000, 27.189), (21.750, 27.189)),
    "Wall_17": ((21.695, 27.261), (20.465, 22.673)),
    "Wall_18": ((20.560, 22.746), (17.810, 22.746)),
    "Wall_19": ((17.938, 22.799), (15.993, 20.854)),
    "Wall_2": ((-58.375, 1.731), (-34.125, 1.731)),
    "Wall_20": ((16.046, 20.982), (16.046, 18.732)),
    "Wall_22": ((16.092, 18.867), (12.985, 14.836)),
    "Wall_23": ((13.106, 14.895), (11.356, 14.895)),
    "Wall_24": ((11.481, 14.951), (9.752, 13.020)),
    "Wall_26": ((9.802, 13.151), (9.802, 10.151)),
    "Wall_27": ((9.877, 10.226), (7.377, 10.226)),
    "Wall_28": ((7.500, 10.283), (4.804, 7.128)),
    "Wall_29": ((4.852, 7.260), (4.862, 1.382)),
    "Wall_30": ((4.760, 1.457), (70.260, 1.457)),
    "Wall_32": ((70.185, 1.532), (70.185, -3.218)),
    "Wall_34": ((-58.300, 1.806), (-58.300, -3.194)),
    "Wall_35": ((-58.375, -3.119), (70.375, -3.119)),
    "Wall_37": ((-34.275, 43.081), (-29.525, 43.081)),
    "Wall_41": ((-29.417, 1.399), (-29.418, 33.149)),
    "Wall_43": ((-29.492, 33.074), (0.508, 33.074)),
    "Wall_44": ((0.433, 33.149), (0.433, 24.399)),
    "Wall_45": ((0.358, 24.474), (14.108, 24.474)),
    "Wall_46": ((14.033, 24.549), (14.033, 22.299)),
    "Wall_47": ((14.082, 22.430), (3.700, 10.488)),
    "Wall_5": ((-34.200, 1.656), (-34.200, 43.156)),
    "Wall_50": ((3.821, 10.525), (2.855, 10.784)),
    "Wall_51": ((2.965, 10.830), (2.090, 9.314)),
    "Wall_52": ((2.075, 9.432), (3.135, 8.371)),
    "Wall_53": ((3.135, 8.478), (2.605, 7.947)),
    "Wall_54": ((2.733, 8.000), (1.983, 8.000)),
    "Wall_55": ((2.085, 8.070), (-0.509, 1.425)),
    "Wall_57": ((-29.492, 1.474), (-0.492, 1.474)),
    "Wall_9": ((-29.466, 43.218), (-29.466, 35.468)),
}


def _ray_to_rectangle(
    origin: np.ndarray, direction: np.ndarray, a: np.ndarray, b: np.ndarray, thickness: float
) -> float:
    """Distance along a 2-D ray to a wall of centre line a-b and the given thickness (inf if missed)."""
    along = (b - a) / np.linalg.norm(b - a)
    normal = np.array([-along[1], along[0]])
    half = thickness / 2
    corners = [a - half * normal, b - half * normal, b + half * normal, a + half * normal]
    best = math.inf
    for p, q in zip(corners, corners[1:] + corners[:1]):
        edge = q - p
        denom = direction[0] * edge[1] - direction[1] * edge[0]
        if abs(denom) < 1e-12:
            continue
        rel = p - origin
        t = (rel[0] * edge[1] - rel[1] * edge[0]) / denom
        s = (rel[0] * direction[1] - rel[1] * direction[0]) / denom
        if t > 0 and 0 <= s <= 1:
            best = min(best, t)
    return best


def _world_ray(sim: Simulator, origin: tuple[float, float, float], angle: float) -> float:
    """mj_ray against collision geoms only, horizontal, from `origin` (above the car so it cannot hit it)."""
    groups = np.zeros(6, np.uint8)
    groups[COLLISION_GROUP] = 1
    geom = np.array([-1], np.int32)
    distance = mujoco.mj_ray(
        sim.model,
        sim.data,
        np.array(origin, float),
        np.array([math.cos(angle), math.sin(angle), 0.0]),
        groups,
        1,
        -1,
        geom,
    )
    return math.inf if distance < 0 else distance


@pytest.mark.parametrize("name", world_names())
def test_car_lands_on_the_ground_and_drives_two_metres(name):
    sim = Simulator(world=name)
    ConstantCommand(sim.bus, sim.scheduler, 1.0, 0.0)
    sim.run_until(1.0)
    (x0, y0, z0), _ = sim.car.state.base_pose()
    ground = GROUND_Z.get(name, 0.0)
    assert z0 == pytest.approx(ground, abs=0.005), "base_link sits on the ground after the 5 cm drop"
    sim.run_until(5.0)  # 4 s at 1 m/s; in `cones` the car pushes the first cones out of its way
    (x, y, z), _ = sim.car.state.base_pose()
    assert x - x0 > 2.0, f"{name}: the car is stuck"
    assert z > ground - 0.01, f"{name}: the car fell through the ground"
    assert abs(y - y0) < 0.5


def test_tunnel_walls_are_where_the_wall_table_puts_them():
    sim = Simulator(world="tunnel")
    origin = np.array([0.0, 0.0])
    walls = [(np.array(a), np.array(b)) for a, b in TUNNEL_WALLS.values()]
    for angle in np.linspace(-math.pi, math.pi, 73)[:-1]:
        direction = np.array([math.cos(angle), math.sin(angle)])
        expected = min(_ray_to_rectangle(origin, direction, a, b, 0.15) for a, b in walls)
        measured = _world_ray(sim, (0.0, 0.0, 1.0), angle)
        if math.isinf(expected):
            assert measured > 60, f"ray at {math.degrees(angle):.0f} deg should leave through an opening"
        else:
            assert measured == pytest.approx(expected, abs=0.01), f"ray at {math.degrees(angle):.0f} deg"


def test_tunnel_corridor_faces_and_heights():
    sim = Simulator(world="tunnel")
    assert _world_ray(sim, (0.0, 0.0, 1.0), -math.pi / 2) == pytest.approx(3.044, abs=0.005)  # Wall_35 inner face
    assert _world_ray(sim, (-2.0, 0.0, 1.0), math.pi / 2) == pytest.approx(1.399, abs=0.005)  # Wall_57 inner face
    assert _world_ray(sim, (-2.0, 0.0, 2.6), math.pi / 2) > 10, "walls are 2.5 m tall"
    world = load_world("tunnel")
    walls = [g for _, g in world.geoms(collides=True) if g.kind == "box"]
    assert len(walls) == 35 and all(g.size[1:] == (0.15, 2.5) for g in walls)


def test_parking_slot_is_between_the_blocks_against_the_wall():
    sim = Simulator(world="parking")
    assert _world_ray(sim, (3.3, 0.0, 1.0), math.pi / 2) == pytest.approx(4.27, abs=0.01)  # the wall
    assert _world_ray(sim, (3.2, 4.0, 0.1), 0.0) == pytest.approx(3.70 - 3.2, abs=0.01)  # block 2 ahead
    assert _world_ray(sim, (3.2, 4.0, 0.1), math.pi) == pytest.approx(3.2 - 2.72, abs=0.01)  # block 1 behind


def test_cones_are_pushable_and_in_a_row():
    sim = Simulator(world="cones")
    cones = [sim.model.body(f"cone_{i}::link") for i in range(1, 6)]
    for i, body in enumerate(cones, start=1):
        assert sim.data.xpos[body.id][:2] == pytest.approx((i, 0.0), abs=1e-9)
        assert sim.model.body_mass[body.id] == pytest.approx(1.0)  # SDF default: no <inertial>
    ConstantCommand(sim.bus, sim.scheduler, 1.0, 0.0)
    sim.run_until(3.0)
    assert np.linalg.norm(sim.data.xpos[cones[0].id][:2] - (1.0, 0.0)) > 0.1, "the first cone was pushed"


def test_ar_tag_is_a_textured_five_centimetre_tag_without_collision():
    world = load_world("ar")
    (tag,) = [(b, g) for b, g in world.geoms() if b.name.startswith("marker_1")]
    body, geom = tag
    assert not geom.collides and geom.texture is not None
    extent = geom.mesh.vertices.max(0) - geom.mesh.vertices.min(0)
    assert extent == pytest.approx((0.001, 0.05, 0.05))
    assert body.pos == pytest.approx((1.0, 0.0, 0.0))
    image = geom.texture
    assert image[..., :3].min() == 0 and image[..., :3].max() == 255, "a black and white marker"


def test_empty_world_is_the_original_racecar_world():
    world = load_world("empty")
    (ground,) = world.bodies
    collision = next(g for g in ground.geoms if g.collides)
    assert (collision.kind, collision.size, collision.mu, collision.mu2) == ("plane", (150.0, 150.0), 100.0, 50.0)
    assert [light.name for light in world.lights] == ["sun"]
    assert world.physics.max_step_size is None and world.physics.gravity == (0.0, 0.0, -9.8)
    assert (world.spawn.x, world.spawn.y, world.spawn.z, world.spawn.yaw) == (0.0, 0.0, 0.05, 0.0)
