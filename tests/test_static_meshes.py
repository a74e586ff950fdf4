"""A static non-convex mesh collides as its surface, as in Gazebo: a car spawned inside a ring-shaped wall is not
inside the ring's convex hull, the lidar sees the inner wall where the geometry puts it, the car drives inside,
and MuJoCo's qhull prints nothing about flat pieces."""

from __future__ import annotations

import math

import numpy as np
import pytest
import trimesh

from racecar_sim import Simulator
from racecar_sim.drivers import ConstantCommand
from racecar_sim.worlds import load_world
from racecar_sim.worlds.mesh_surface import SLAB_THICKNESS, surface_pieces
from racecar_sim.worlds.world import Mesh, Spawn

OUTER, INNER, HEIGHT = 4.0, 3.5, 0.5  # half sides of the square ring wall, its height (m)
SHEET_AT = (6.0, 0.0)  # where the flat U-shaped sheet lies, outside the ring
U_CELLS = [(0, 0), (1, 0), (2, 0), (0, 1), (2, 1)]  # unit squares of the U (its notch is the square (1, 1))
SHEET_NOISE = 1e-9  # m


def _quad(a: int, b: int, c: int, d: int) -> list[tuple[int, int, int]]:
    return [(a, b, c), (a, c, d)]


def ring_mesh(outer: float = OUTER, inner: float = INNER, height: float = HEIGHT) -> trimesh.Trimesh:
    """A closed square ring wall around the origin: outer and inner half sides, height."""
    square = np.array([(1, -1), (1, 1), (-1, 1), (-1, -1)], float)  # counter-clockwise seen from above
    vertices = [(x, y, z) for z in (0.0, height) for side in (outer, inner) for x, y in square * side]

    def at(level: int, ring: int, k: int) -> int:
        return level * 8 + ring * 4 + k % 4

    faces = []
    for k in range(4):
        faces += _quad(at(1, 0, k), at(1, 0, k + 1), at(1, 1, k + 1), at(1, 1, k))  # top, facing up
        faces += _quad(at(0, 0, k), at(0, 1, k), at(0, 1, k + 1), at(0, 0, k + 1))  # bottom, facing down
        faces += _quad(at(0, 0, k), at(0, 0, k + 1), at(1, 0, k + 1), at(1, 0, k))  # outer side, facing out
        faces += _quad(at(0, 1, k), at(1, 1, k), at(1, 1, k + 1), at(0, 1, k + 1))  # inner side, facing in
    mesh = trimesh.Trimesh(np.array(vertices), np.array(faces), process=False)
    assert mesh.is_watertight and mesh.volume > 0 and not mesh.is_convex
    return mesh


def u_sheet() -> trimesh.Trimesh:
    """A flat U of five unit squares facing up, two triangles each: one non-convex planar region. Its corners are
    off the plane by up to SHEET_NOISE, as a CAD export's are: enough for qhull to print warnings about its hull
    (an exactly flat one MuJoCo rejects outright)."""
    vertices, faces = [], []
    for x, y in U_CELLS:
        base = len(vertices)
        vertices += [(x, y, 0.0), (x + 1, y, 0.0), (x + 1, y + 1, 0.0), (x, y + 1, 0.0)]
        faces += _quad(base, base + 1, base + 2, base + 3)
    sheet = trimesh.Trimesh(np.array(vertices, float), np.array(faces), process=True)  # merges shared corners
    sheet.vertices[:, 2] += SHEET_NOISE * (np.arange(len(sheet.vertices)) % 3) / 2
    return sheet


def _outside(piece: Mesh, point: np.ndarray) -> bool:
    """Whether `point` is outside the convex hull of the piece."""
    hull = trimesh.Trimesh(piece.vertices, piece.faces).convex_hull
    return bool(np.max((point - hull.triangles[:, 0]) @ hull.face_normals.T) > 1e-9)


def test_a_ring_is_cut_into_convex_pieces_that_stay_inside_the_wall():
    pieces, flat = surface_pieces(Mesh(ring_mesh().vertices, ring_mesh().faces))
    assert flat == len(pieces) > 1
    for piece in pieces:
        tm = trimesh.Trimesh(piece.vertices, piece.faces)
        assert tm.is_convex and tm.volume > 0
        ring = np.max(np.abs(piece.vertices[:, :2]), axis=1)  # square "radius" of every corner
        assert np.all((ring >= INNER - 1e-9) & (ring <= OUTER + 1e-9))
        assert np.all((piece.vertices[:, 2] >= -1e-9) & (piece.vertices[:, 2] <= HEIGHT + 1e-9))
        assert _outside(piece, np.array([0.0, 0.0, HEIGHT / 2]))  # the hole is free


def test_a_flat_non_convex_sheet_becomes_thin_convex_slabs_behind_its_face():
    sheet = u_sheet()
    pieces, flat = surface_pieces(Mesh(sheet.vertices, sheet.faces))
    assert 2 <= flat == len(pieces) <= len(U_CELLS)  # merged beyond single triangles, never across the notch
    area = 0.0
    for piece in pieces:
        tm = trimesh.Trimesh(piece.vertices, piece.faces)
        assert tm.is_convex
        assert piece.vertices[:, 2].max() == pytest.approx(0.0, abs=SHEET_NOISE)  # the face stays where it was
        assert np.ptp(piece.vertices[:, 2]) == pytest.approx(SLAB_THICKNESS)  # behind it, against the normal
        area += tm.volume / SLAB_THICKNESS
        assert _outside(piece, np.array([1.5, 1.5, -SLAB_THICKNESS / 2]))  # the notch is free
    assert area == pytest.approx(len(U_CELLS))


def test_a_convex_static_mesh_stays_one_piece():
    box = trimesh.creation.box((1.0, 2.0, 0.5))
    pieces, flat = surface_pieces(Mesh(box.vertices, box.faces))
    assert flat == 0 and len(pieces) == 1
    assert np.allclose(np.sort(pieces[0].vertices, axis=0), np.sort(box.vertices, axis=0))


def _world(tmp_path, static: bool = True) -> str:
    ring_mesh().export(tmp_path / "ring.stl")
    u_sheet().export(tmp_path / "sheet.stl")
    path = tmp_path / "ring.world"
    mesh = "<geometry><mesh><uri>{}</uri></mesh></geometry>"
    path.write_text(f"""<?xml version="1.0"?>
<sdf version="1.6"><world name="ring">
  <include><uri>model://sun</uri></include>
  <include><uri>model://ground_plane</uri></include>
  <model name="ring"><static>{int(static)}</static><link name="link">
    <collision name="collision">{mesh.format("ring.stl")}</collision>
    <visual name="visual">{mesh.format("ring.stl")}</visual></link></model>
  <model name="sheet"><static>true</static><pose>{SHEET_AT[0]} {SHEET_AT[1]} 0.001 0 0 0</pose><link name="link">
    <collision name="collision">{mesh.format("sheet.stl")}</collision></link></model>
</world></sdf>""")
    return str(path)


def test_a_car_inside_a_static_ring_sees_the_wall_and_drives(tmp_path, capfd):
    world_file = _world(tmp_path)
    flat = r"collision is not convex: as in Gazebo, it collides as its faces where it is not \(\d+ flat pieces"
    with (
        pytest.warns(UserWarning, match=r"ring\.stl</uri> in ring::link/" + flat),
        pytest.warns(UserWarning, match=r"sheet\.stl</uri> in sheet::link/" + flat),
    ):
        world = load_world(world_file, Spawn(0.0, 0.0, 0.05, 0.0))
    sim = Simulator(world=world, camera=False)  # the spawn check passes: the ring's hull would hold the car
    assert "QH" not in capfd.readouterr().err  # the sheet's flat pieces compile without qhull's precision warnings

    lidar = sim.car.lidar
    ranges = lidar.true_ranges()
    origin, axes = lidar.ray_origin()
    angles = lidar.spec.min_angle + lidar.spec.angle_increment * np.arange(lidar.spec.samples)
    directions = np.stack([np.cos(angles), np.sin(angles), np.zeros_like(angles)], axis=1) @ axes.T
    with np.errstate(divide="ignore", invalid="ignore"):  # beams along an axis never meet the walls across it
        to_wall = (np.sign(directions[:, :2]) * INNER - origin[:2]) / directions[:, :2]
    expected = np.min(np.where(np.isfinite(to_wall), to_wall, np.inf), axis=1)  # the first inner face a beam meets
    assert np.all(np.isfinite(ranges))
    assert np.max(np.abs(ranges - expected)) < 1e-4

    steering = 0.3  # a circle of radius wheelbase / tan(0.3), about 1.05 m, well inside the ring
    ConstantCommand(sim.bus, sim.scheduler, 1.0, steering)
    path = []
    for _ in range(60):
        sim.run_for(0.1)
        path.append(sim.data.qpos[:2].copy())
    path = np.array(path)
    travelled = np.sum(np.linalg.norm(np.diff(path, axis=0), axis=1))
    assert travelled > 0.8 * 5.9  # nothing stopped it: 1 m/s after a short start
    assert np.max(np.abs(path)) < INNER - 0.5
    heading_change = np.unwrap(np.arctan2(*(np.diff(path, axis=0)[:, ::-1].T)))
    assert abs(heading_change[-1] - heading_change[0]) > math.pi / 2  # it really turned, on its circle


def test_a_free_model_with_the_same_mesh_collides_as_its_hull(tmp_path):
    with (
        pytest.warns(UserWarning, match="ring.stl</uri> .* collides as the convex hull of each of its connected"),
        pytest.warns(UserWarning, match="sheet.stl</uri> .* collides as its faces"),
    ):
        world = load_world(_world(tmp_path, static=False))
    ring = next(body for body in world.bodies if body.name == "ring::link")
    assert not ring.static
    assert len([geom for geom in ring.geoms if geom.collides]) == 1
