"""Occupancy maps: occupied cells merge into few boxes lying exactly on the cells, and rays see them there."""

from __future__ import annotations

import math
from pathlib import Path

import mujoco
import numpy as np
import pytest
from PIL import Image

from conftest import run_cli_error
from racecar_sim import Simulator
from racecar_sim.core.errors import WorldError
from racecar_sim.drivers import ConstantCommand
from racecar_sim.physics.builder import COLLISION_GROUP
from racecar_sim.physics.near_walls import WallBoxes
from racecar_sim.worlds import load_world
from racecar_sim.worlds.occupancy_map import occupied_cells
from racecar_sim.worlds.walls import cell_rectangles

RES, ROWS, COLS = 0.05, 80, 100
WALL = 2  # cells
PILLAR = (20, 70, 30, 80)  # row0, col0, row1, col1 (half-open)
UNKNOWN = (60, 35, 66, 45)  # grey patch between the spawn point and the bottom wall
LIDAR_HEIGHT = 0.15  # m
FREE, OCCUPIED, GREY = 254, 0, 128  # map_saver's free and occupied grey levels, and an unknown one


def room_image() -> np.ndarray:
    """A 5 m x 4 m room with 2-cell walls, a square pillar and an unknown patch (grey levels, row 0 on top)."""
    img = np.full((ROWS, COLS), FREE, dtype=np.uint8)
    img[:WALL], img[-WALL:], img[:, :WALL], img[:, -WALL:] = OCCUPIED, OCCUPIED, OCCUPIED, OCCUPIED
    r0, c0, r1, c1 = PILLAR
    img[r0:r1, c0:c1] = OCCUPIED
    r0, c0, r1, c1 = UNKNOWN
    img[r0:r1, c0:c1] = GREY
    return img


def write_map(
    folder: Path,
    image: np.ndarray,
    origin: tuple[float, float, float],
    negate: int = 0,
    name: str = "room",
    suffix: str = ".pgm",
) -> Path:
    """room.yaml and its image, as map_saver writes them."""
    Image.fromarray(image).save(folder / f"{name}{suffix}")
    yaml_path = folder / f"{name}.yaml"
    yaml_path.write_text(
        f"image: {name}{suffix}\nresolution: {RES}\norigin: [{origin[0]}, {origin[1]}, {origin[2]}]\n"
        f"negate: {negate}\noccupied_thresh: 0.65\nfree_thresh: 0.196\n"
    )
    return yaml_path


def obstacles_in_map_frame() -> list[tuple[float, float, float, float]]:
    """(xmin, ymin, xmax, ymax) of the walls and the pillar, metres from the map's bottom-left corner."""

    def box(r0: int, c0: int, r1: int, c1: int) -> tuple[float, float, float, float]:
        return c0 * RES, (ROWS - r1) * RES, c1 * RES, (ROWS - r0) * RES

    return [
        box(0, 0, WALL, COLS),
        box(ROWS - WALL, 0, ROWS, COLS),
        box(0, 0, ROWS, WALL),
        box(0, COLS - WALL, ROWS, COLS),
        box(*PILLAR),
    ]


def expected_range(start: np.ndarray, direction: np.ndarray) -> float:
    """Distance along a 2-D ray (map frame) to the first obstacle, by the slab method."""
    best = math.inf
    for xmin, ymin, xmax, ymax in obstacles_in_map_frame():
        with np.errstate(divide="ignore"):
            t1 = (np.array([xmin, ymin]) - start) / direction
            t2 = (np.array([xmax, ymax]) - start) / direction
        near, far = np.nanmax(np.minimum(t1, t2)), np.nanmin(np.maximum(t1, t2))
        if near <= far and near >= 0:
            best = min(best, near)
    return best


def cast(sim: Simulator, x: float, y: float, yaw: float) -> tuple[float, str]:
    """Range and geom name of a horizontal ray at lidar height, seeing only collision geoms, not the car."""
    geomgroup = np.zeros(6, dtype=np.uint8)
    geomgroup[COLLISION_GROUP] = 1
    geomid = np.zeros(1, dtype=np.int32)
    base = sim.model.body(sim.car.robot.root).id
    distance = mujoco.mj_ray(
        sim.model,
        sim.data,
        np.array([x, y, LIDAR_HEIGHT]),
        np.array([math.cos(yaw), math.sin(yaw), 0.0]),
        geomgroup,
        1,
        base,
        geomid,
    )
    return distance, sim.model.geom(geomid[0]).name


# --- cell_rectangles ----------------------------------------------------------------------------------------------


@pytest.mark.parametrize("seed", range(20))
def test_rectangles_cover_exactly_the_occupied_cells_without_overlap(seed):
    rng = np.random.default_rng(seed)
    grid = rng.random(tuple(rng.integers(1, 40, size=2))) < rng.random()
    coverage = np.zeros(grid.shape, dtype=int)
    for r0, c0, r1, c1 in cell_rectangles(grid):
        assert 0 <= r0 < r1 <= grid.shape[0] and 0 <= c0 < c1 <= grid.shape[1]
        coverage[r0:r1, c0:c1] += 1
    np.testing.assert_array_equal(coverage, grid.astype(int))


def test_solid_block_is_one_rectangle_and_room_outline_four():
    block = np.zeros((30, 40), dtype=bool)
    block[5:25, 3:37] = True
    assert cell_rectangles(block) == [(5, 3, 25, 37)]
    assert cell_rectangles(np.zeros((3, 3), dtype=bool)) == []
    assert len(cell_rectangles(room_image() == OCCUPIED)) == 5  # four walls and the pillar


def test_a_wall_meeting_another_is_two_boxes_and_an_askew_wall_one_per_step():
    tee = np.zeros((12, 12), dtype=bool)
    tee[1:11, 5] = True  # a wall with another branching off its middle: merging rows would cut it in three
    tee[6, 6:11] = True
    assert sorted(cell_rectangles(tee)) == [(1, 5, 11, 6), (6, 6, 7, 11)]
    askew = np.zeros((10, 100), dtype=bool)
    askew[np.arange(100) // 10, np.arange(100)] = True  # a wall at 1 in 10, as a scan draws it: ten steps
    assert cell_rectangles(askew) == [(k, 10 * k, k + 1, 10 * k + 10) for k in range(10)]


def scanned_map() -> np.ndarray:
    """A scanned map's occupancy (row 0 on top): one-cell walls at several angles, a thick wall, speckle."""
    rng = np.random.default_rng(7)
    grid = np.zeros((160, 200), dtype=bool)
    for (r0, c0), (r1, c1) in [
        ((5, 5), (5, 195)),
        ((5, 5), (155, 12)),
        ((155, 12), (150, 195)),
        ((20, 40), (120, 140)),
        ((30, 150), (140, 170)),
    ]:  # 0, 3, 2, 45 and 80 degrees
        n = max(abs(r1 - r0), abs(c1 - c0)) + 1
        grid[np.rint(np.linspace(r0, r1, n)).astype(int), np.rint(np.linspace(c0, c1, n)).astype(int)] = True
    grid[60:64, 20:90] = True
    grid[tuple(rng.integers(0, 160, (2, 80)))] = True
    grid[tuple(rng.integers(0, 160, (2, 80)) + [[0], [40]])] = True
    return grid


@pytest.mark.parametrize("near_walls", [True, False])
def test_scanned_map_merges_into_few_boxes_on_exactly_its_occupied_cells(tmp_path, near_walls):
    """The compiled model's wall boxes, read back from MuJoCo, cover each occupied cell once and nothing else: as
    geoms, or as the model's held-out walls (physics.near_walls) when they are that many."""
    occupied = scanned_map()
    image = np.where(occupied, OCCUPIED, FREE).astype(np.uint8)
    sim = Simulator(
        world=str(write_map(tmp_path, image, (-1.0, -1.0, 0.0), name="scan")),
        lidar=False,
        camera=False,
        near_walls=near_walls,
    )
    model, data = sim.model, sim.data
    walls = [
        g
        for g in range(model.ngeom)
        if model.geom(g).name.startswith("map_wall") and model.geom_group[g] == COLLISION_GROUP
    ]
    assert all(model.geom_type[g] == mujoco.mjtGeom.mjGEOM_BOX for g in walls)
    held = WallBoxes.of(model)
    assert (held is not None) == near_walls and (len(walls) == 0) == near_walls
    if held is None:
        boxes = [(data.geom_xpos[g], data.geom_xmat[g], model.geom_size[g]) for g in walls]
    else:
        boxes = list(zip(held.pos, held.rotations().reshape(-1, 9), held.half))
    assert len(boxes) < occupied.sum() / 4
    rows = occupied.shape[0]
    coverage = np.zeros(occupied.shape, dtype=int)
    for pos, rotation, half in boxes:
        np.testing.assert_allclose(rotation, np.eye(3).ravel(), atol=1e-12)
        lo = (pos[:2] - half[:2] - (-1.0, -1.0)) / RES
        hi = (pos[:2] + half[:2] - (-1.0, -1.0)) / RES
        np.testing.assert_allclose(np.r_[lo, hi], np.round(np.r_[lo, hi]), atol=1e-6)  # on cell boundaries
        c0, y0, c1, y1 = np.round(np.r_[lo, hi]).astype(int)
        coverage[rows - y1 : rows - y0, c0:c1] += 1
    np.testing.assert_array_equal(coverage, occupied.astype(int))


def test_the_car_stops_at_the_face_of_the_occupied_cells(tmp_path):
    """Driving straight into a wall of cells, the car touches it on the cells' edge and goes no further."""
    image = np.full((40, 120), FREE, dtype=np.uint8)
    image[:, 80:83] = OCCUPIED  # the wall's near face at column 80: x = -2 + 80 * 0.05 = 2.0 m
    image[10, 40:60] = OCCUPIED  # a thin wall beside the car's path, so that the map is several boxes
    sim = Simulator(world=str(write_map(tmp_path, image, (-2.0, -1.0, 0.0), name="wall")), lidar=False, camera=False)
    ConstantCommand(sim.bus, sim.scheduler, 1.0, 0.0)
    touches = []
    for k in range(40):
        sim.run_until(0.1 * (k + 1))
        for contact in sim.data.contact[: sim.data.ncon]:
            names = [sim.model.geom(g).name for g in contact.geom]
            if any(n.startswith("map_wall") for n in names):
                touches.append(contact.pos[0] + 0.5 * contact.dist)  # the wall's side of the contact
    assert touches, "the car never reached the wall"
    np.testing.assert_allclose(touches, 2.0, atol=2e-3)


# --- loading a map ------------------------------------------------------------------------------------------------


def test_room_walls_are_few_boxes_on_the_cells(tmp_path):
    world = load_world(write_map(tmp_path, room_image(), (-2.0, -1.5, 0.0)), wall_height=0.8)
    (ground, body) = world.bodies[0], world.bodies[-1]
    assert ground.geoms[0].kind == "plane" and world.lights[0].name == "sun"
    collision = [g for g in body.geoms if g.collides]
    visual = [g for g in body.geoms if not g.collides]
    assert len(collision) == len(visual) == 5
    np.testing.assert_allclose(body.pos, [-2.0, -1.5, 0.0])
    coverage = np.zeros((ROWS, COLS), dtype=int)
    for g in collision:
        xmin, ymin = (g.pos[:2] - np.array(g.size[:2]) / 2) / RES
        xmax, ymax = (g.pos[:2] + np.array(g.size[:2]) / 2) / RES
        edges = np.array([xmin, ymin, xmax, ymax])
        np.testing.assert_allclose(edges, np.round(edges), atol=1e-9)  # on cell boundaries
        c0, r1, c1, r0 = np.round(edges).astype(int)  # y grows upwards, rows downwards
        coverage[ROWS - r0 : ROWS - r1, c0:c1] += 1
    np.testing.assert_array_equal(coverage, (room_image() == OCCUPIED).astype(int))
    assert all(g.pos[2] - g.size[2] / 2 == pytest.approx(0.0) and g.size[2] == pytest.approx(0.8) for g in collision)
    assert (world.spawn.x, world.spawn.y, world.spawn.yaw) == (0.0, 0.0, 0.0)


VARIANTS = {
    "plain": (lambda img: img, 0, (-2.0, -1.5, 0.0)),
    "negate": (lambda img: 255 - img, 1, (-2.0, -1.5, 0.0)),
    # yaw turns the map about its origin corner: the spawn point (0, 0) lands on the same cell as above
    "yaw": (lambda img: img, 0, (1.5, -2.0, math.pi / 2)),
}


@pytest.mark.parametrize("variant", VARIANTS)
def test_rays_from_the_spawn_point_hit_the_mapped_walls(tmp_path, variant):
    transform, negate, origin = VARIANTS[variant]
    sim = Simulator(world=str(write_map(tmp_path, transform(room_image()), origin, negate)))
    sim.run_until(0.5)  # settled: the wheel tops sink from 0.15 m to 0.10 m, below the rays
    ox, oy, yaw = origin
    rotation = np.array([[math.cos(yaw), math.sin(yaw)], [-math.sin(yaw), math.cos(yaw)]])  # world -> map frame
    start = rotation @ np.array([0.0 - ox, 0.0 - oy])
    pillar = np.array([(PILLAR[1] + PILLAR[3]) / 2 * RES, (ROWS - (PILLAR[0] + PILLAR[2]) / 2) * RES])
    toward_pillar = math.atan2(*(pillar - start)[::-1])
    for map_angle in [0.0, 0.5 * math.pi, math.pi, 1.5 * math.pi, 0.6, 2.4, 4.0, 5.3, toward_pillar]:
        expected = expected_range(start, np.array([math.cos(map_angle), math.sin(map_angle)]))
        distance, geom = cast(sim, 0.0, 0.0, map_angle + yaw)
        assert geom.startswith("map_wall")
        assert distance == pytest.approx(expected, abs=1e-6), (variant, map_angle)
    # the ray straight down (map frame) crossed the unknown patch and still reached the bottom wall
    assert expected_range(start, np.array([0.0, -1.0])) == pytest.approx(1.4)


def test_colour_pixels_are_averaged_like_map_server(tmp_path):
    # magenta averages to 170 (p = 0.33, below 0.45); by luminance it would be 105 (p = 0.59, occupied)
    pixels = np.array([[[0, 0, 0], [255, 0, 255], [255, 255, 255]]], dtype=np.uint8)
    Image.fromarray(pixels).save(tmp_path / "c.png")
    (tmp_path / "c.yaml").write_text(
        "image: c.png\nresolution: 1.0\norigin: [10, 10, 0]\nnegate: 0\noccupied_thresh: 0.45\nfree_thresh: 0.1\n"
    )
    (box,) = [g for _, g in load_world(tmp_path / "c.yaml").geoms(collides=True) if g.kind == "box"]
    np.testing.assert_allclose(box.pos[:2], [0.5, 0.5])


@pytest.mark.parametrize(
    ("mode", "negate", "expected"),
    [
        ("trinary", 0, [True, True, False, False, False]),  # p = 1, 0.69, 0.5, 0.2, 0
        ("trinary", 1, [False, False, False, True, True]),  # p = 0, 0.31, 0.5, 0.8, 1
        ("raw", 0, [False, True, False, False, False]),  # percent: 0, 80, 128 (> 100: unknown), 204, 255
    ],
)
def test_map_modes_mark_occupied_cells_as_map_server_does(mode, negate, expected):
    grey = np.array([[0.0, 80.0, 128.0, 204.0, 255.0]])
    meta = {"mode": mode, "negate": negate, "occupied_thresh": 0.65, "free_thresh": 0.196}
    assert occupied_cells(grey, None, meta).tolist() == [expected]


def test_spawn_in_a_wall_is_an_error_naming_the_file(tmp_path):
    """An occupied cell is an obstacle: a car spawned on one is refused, as in every world (issue 10)."""
    path = write_map(tmp_path, room_image(), (0.0, 0.0, 0.0))  # the origin is the bottom-left wall corner
    load_world(path)  # the map itself loads; the car cannot start there
    with pytest.raises(
        WorldError,
        match=r"room\.yaml: spawn pose \(0, 0, 0\.05, 0\) is inside an obstacle: .* into "
        r"map_wall",
    ):
        Simulator(world=str(path), lidar=False, camera=False)


# --- malformed maps: one line on stderr, exit code 2 --------------------------------------------------------------

BAD_MAPS = {
    "missing_image.yaml": ("image: nowhere.pgm\nresolution: 0.05\norigin: [0, 0, 0]\n", "image: "),
    "bad_syntax.yaml": ("image: room.pgm\nresolution: [0.05\norigin: [0, 0, 0]\n", "invalid YAML"),
    "nan_resolution.yaml": ("image: room.pgm\nresolution: .nan\norigin: [0, 0, 0]\n", "resolution: "),
    "nan_origin.yaml": ("image: room.pgm\nresolution: 0.05\norigin: [0, .nan, 0]\n", "origin: "),
    "no_image.yaml": ("resolution: 0.05\norigin: [0, 0, 0]\n", "image: missing"),
    "bad_negate.yaml": ("image: room.pgm\nresolution: 0.05\norigin: [0, 0, 0]\nnegate: 2\n", "negate: "),
    "bad_thresh.yaml": (
        "image: room.pgm\nresolution: 0.05\norigin: [0, 0, 0]\noccupied_thresh: 1.5\n",
        "occupied_thresh: ",
    ),
}


@pytest.mark.parametrize("name", ["missing_image.yaml", "bad_syntax.yaml", "nan_resolution.yaml"])
def test_malformed_map_fails_in_one_line_from_the_cli(tmp_path, name):
    Image.fromarray(room_image()).save(tmp_path / "room.pgm")
    content, field = BAD_MAPS[name]
    (tmp_path / name).write_text(content)
    assert field in run_cli_error(tmp_path / name)


@pytest.mark.parametrize("name", BAD_MAPS)
def test_malformed_map_error_names_file_and_field(tmp_path, name):
    Image.fromarray(room_image()).save(tmp_path / "room.pgm")
    content, field = BAD_MAPS[name]
    (tmp_path / name).write_text(content)
    with pytest.raises(WorldError) as error:
        load_world(tmp_path / name)
    message = str(error.value)
    assert "\n" not in message and name in message and field in message


def test_unreadable_image_names_the_file(tmp_path):
    (tmp_path / "room.pgm").write_bytes(b"not an image")
    (tmp_path / "m.yaml").write_text("image: room.pgm\nresolution: 0.05\norigin: [0, 0, 0]\n")
    with pytest.raises(WorldError, match=r"m\.yaml: image: cannot read .*room\.pgm"):
        load_world(tmp_path / "m.yaml")
