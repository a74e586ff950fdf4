"""Issue 21's world files at their hard edges: a box kilometres wide, an <include> loop, two models of one name, a map
image too large to decode, values MuJoCo refuses (a negative inertia, a one-triangle free mesh, a track at 1e300, a
1e308 m wall height) and a map written with `5e-2`. Each is either taken at no cost that grows with its size, or
refused in one line naming the file and what is at fault, with exit code 2 on the CLI."""

from __future__ import annotations

import math
import struct
import zlib
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from racecar_sim import Simulator
from racecar_sim.cli.main import main
from racecar_sim.core.errors import RacecarSimError, WorldError
from racecar_sim.sensors.raycast import grid as raycast_grid
from racecar_sim.worlds import Spawn, load_world
from racecar_sim.worlds.world import Mesh, WorldBody, WorldGeom

SDF = '<sdf version="1.6"><world name="w">{}</world></sdf>'
GROUND = "<include><uri>model://ground_plane</uri></include>"
IDENTITY = np.array([1.0, 0.0, 0.0, 0.0])


def cli_error(capsys: pytest.CaptureFixture, tmp_path: Path, *args: str) -> str:
    """The one stderr line of `racecar-sim run ARGS`, which must exit with code 2."""
    code = main(["run", *args, "--duration", "0.1", "--no-camera", "--no-record", "--out", str(tmp_path / "out")])
    err = capsys.readouterr().err
    assert code == 2, err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("racecar-sim: error: "), err
    return lines[0]


def box_model(name: str, size: str, pose: str, static: bool = True, inertial: str = "") -> str:
    return (
        f'<model name="{name}"><static>{str(static).lower()}</static><pose>{pose}</pose><link name="link">'
        f'{inertial}<collision name="c"><geometry><box><size>{size}</size></box></geometry></collision>'
        f'<visual name="v"><geometry><box><size>{size}</size></box></geometry></visual></link></model>'
    )


def world_file(folder: Path, name: str, *models: str) -> Path:
    path = folder / name
    path.write_text(SDF.format("".join(models)))
    return path


# --- 1. the lidar's grid does not grow with the size of a box -------------------------------------------------------


def tilted_scan(sim: Simulator) -> np.ndarray:
    """A scan from 0.3 m up, pitched 0.1 rad down: its beams reach the ground 3 m ahead."""
    c, s = math.cos(0.1), math.sin(0.1)
    return sim.car.lidar.caster.cast(np.array([0.0, 0.0, 0.3]), np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]]))


@pytest.mark.parametrize("side", ["1e4", "1e5", "1e9"])
def test_a_ground_box_of_any_size_is_a_few_long_walls_and_the_lidar_sees_it_as_a_floor(tmp_path, side):
    ground = box_model("ground", f"{side} {side} 0.1", "0 0 -0.05 0 0 0")
    sim = Simulator(world=str(world_file(tmp_path, "big.sdf", ground)), camera=False)
    grid = sim.car.lidar.caster.grid
    assert len(grid.cells) == 0 and grid.empty.segments.shape[1] == 4  # its 4 edges, in no cell of their own
    plane = Simulator(world="empty", camera=False)
    assert np.array_equal(tilted_scan(sim), tilted_scan(plane))  # the box's top is seen where the plane is
    assert np.isfinite(tilted_scan(sim)).sum() > 500


def test_a_1e9_m_ground_box_runs_from_the_cli(tmp_path, capsys):
    path = world_file(tmp_path, "big.sdf", box_model("ground", "1e9 1e9 0.1", "0 0 -0.05 0 0 0"))
    code = main(
        ["run", "--world", str(path), "--duration", "0.2", "--no-camera", "--no-record", "--out", str(tmp_path / "out")]
    )
    assert code == 0, capsys.readouterr().err


def test_long_walls_give_the_scans_of_walls_registered_in_every_cell(tmp_path, monkeypatch):
    long_wall = box_model("long", "3000 0.2 1", "0 2 0.5 0 0 0.3")
    round_pad = (
        '<model name="pad"><static>true</static><pose>0 250 0.5 0 0 0</pose><link name="l"><collision '
        'name="c"><geometry><cylinder><radius>200</radius><length>1</length></cylinder></geometry>'
        "</collision></link></model>"
    )
    sim = Simulator(
        world=str(
            world_file(
                tmp_path, "long.sdf", GROUND, long_wall, round_pad, box_model("block", "1 1 1", "4 0 0.5 0 0 0.7")
            )
        ),
        camera=False,
    )
    caster = sim.car.lidar.caster
    assert caster.grid.empty.segments.shape[1] == 2 and caster.grid.empty.circles.shape[1] == 1
    monkeypatch.setattr(raycast_grid, "LONG_CELLS", 10**12)
    every_cell = raycast_grid.Grid(caster.static, caster.fan)  # as before: each item in every cell it reaches
    mine = caster.grid
    rng = np.random.default_rng(3)
    for _ in range(60):
        yaw, tilt = rng.uniform(-math.pi, math.pi), rng.choice([0.0, 0.03, 0.1])
        c, s, ct, st = math.cos(yaw), math.sin(yaw), math.cos(tilt), math.sin(tilt)
        axes = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1.0]]) @ np.array([[ct, 0, st], [0, 1, 0], [-st, 0, ct]])
        origin = np.array([*rng.uniform(-60, 60, 2), 0.3])
        caster.grid = every_cell
        expected = caster.cast(origin, axes)
        caster.grid = mine
        assert np.array_equal(caster.cast(origin, axes), expected)


def test_boxes_kilometres_apart_build_no_table_spanning_the_gap(tmp_path):
    far = [box_model(f"b{i}", "1 1 1", f"{x} {y} 0.5 0 0 0") for i, (x, y) in enumerate([(3, 0), (1e6, 1e6)])]
    sim = Simulator(world=str(world_file(tmp_path, "far.sdf", GROUND, *far)), camera=False)
    assert sim.car.lidar.caster.level_walls() is None  # cells 1e6 m apart: no look-up table of 4e10 cells
    sim.run_until(0.1)
    assert np.isfinite(sim.car.lidar.scan(0)).any()


def test_a_map_kilometres_across_sizes_its_near_wall_slots_without_a_table_of_its_square_metres(tmp_path):
    cells = np.zeros((40, 40), bool)
    cells[::2, ::2] = True  # 400 one-cell boxes, 1 km each: held out of the collision model (near_walls)
    cells[20, 20] = False
    Image.fromarray(np.where(cells, 0, 254).astype(np.uint8)).save(tmp_path / "dots.pgm")
    (tmp_path / "dots.yaml").write_text("image: dots.pgm\nresolution: 1000\norigin: [-20000, -20000, 0]\n")
    sim = Simulator(world=str(tmp_path / "dots.yaml"), camera=False, spawn=Spawn(500.0, 500.0, 0.05, 0.0))
    assert sim.near_walls is not None and len(sim.near_walls.geoms) <= 400


def test_a_box_beyond_the_largest_coordinate_is_one_line(tmp_path, capsys):
    path = world_file(tmp_path, "huge.sdf", box_model("ground", "3e9 3e9 0.1", "0 0 -0.05 0 0 0"))
    line = cli_error(capsys, tmp_path, "--world", str(path))
    assert "huge.sdf" in line and "ground::link" in line and "1e+09 m" in line


# --- 2. <include> loops ---------------------------------------------------------------------------------------------


def model_folder(root: Path, name: str, body: str) -> None:
    (root / name).mkdir(parents=True)
    (root / name / "model.sdf").write_text(f'<sdf version="1.6"><model name="{name}">{body}</model></sdf>')


@pytest.mark.parametrize("chain", [["loop"], ["a", "b"]])
def test_an_include_loop_is_one_line_naming_the_file_and_the_uris(tmp_path, capsys, chain):
    models = tmp_path / "models"
    for name, then in zip(chain, chain[1:] + chain[:1]):
        model_folder(models, name, f"<include><uri>model://{then}</uri></include>")
    path = world_file(tmp_path, "loop.sdf", GROUND, f"<include><uri>model://{chain[0]}</uri></include>")
    line = cli_error(capsys, tmp_path, "--world", str(path), "--model-path", str(models))
    assert "loop.sdf" in line and "<include> loop" in line
    assert " -> ".join(f"model://{name}" for name in [*chain, chain[0]]) in line
    with pytest.raises(WorldError):
        load_world(path, model_path=[models])


def test_models_nested_a_thousand_deep_are_one_line_not_a_recursion_error(tmp_path, capsys):
    link = '<link name="l"><collision name="c"><geometry><box><size>1 1 1</size></box></geometry></collision></link>'
    nested = "".join(f'<model name="m{i}">' for i in range(1000)) + link + "</model>" * 1000
    nested = nested.replace('<model name="m0">', '<model name="m0"><static>true</static><pose>5 0 0.5 0 0 0</pose>', 1)
    line = cli_error(capsys, tmp_path, "--world", str(world_file(tmp_path, "deep.sdf", GROUND, nested)))
    assert "deep.sdf: model m0: models nested more than 64 deep" in line


# --- 3. two models of one name --------------------------------------------------------------------------------------


def test_two_models_of_one_name_are_one_line_naming_the_file_and_the_model(tmp_path, capsys):
    path = world_file(
        tmp_path,
        "twins.sdf",
        GROUND,
        box_model("twin", "1 1 1", "3 0 0.5 0 0 0"),
        box_model("twin", "1 1 1", "-3 0 0.5 0 0 0"),
    )
    line = cli_error(capsys, tmp_path, "--world", str(path))
    assert "twins.sdf" in line and "two models named 'twin'" in line


def test_two_geoms_of_one_name_in_a_world_built_in_python_are_a_world_error(tmp_path):
    world = load_world("empty")
    box = WorldGeom("twin::link/c", "box", (1.0, 1.0, 1.0), np.zeros(3), IDENTITY)
    for x in (3.0, -3.0):
        world.bodies.append(WorldBody("twin::link", np.array([x, 0.0, 0.5]), IDENTITY, geoms=[box]))
    with pytest.raises(WorldError, match=r"^empty \(racecar\.world\): two geoms named 'twin::link/c'"):
        Simulator(world=world, camera=False)


# --- 4. a map image too large to decode -----------------------------------------------------------------------------


def png_header(width: int, height: int) -> bytes:
    """A PNG that is only its header: enough for anything that looks at the size before decoding."""

    def chunk(kind: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)

    return (
        b"\x89PNG\r\n\x1a\n"
        + chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, 0, 0, 0, 0))
        + chunk(b"IEND", b"")
    )


@pytest.mark.parametrize("image", ["huge.png", "huge.pgm", "wide.pgm"])
def test_a_map_image_larger_than_the_largest_map_is_one_line_before_decoding(tmp_path, capsys, image):
    width, height = (20000, 20000) if image.startswith("huge") else (70000, 1000)
    data = png_header(width, height) if image.endswith(".png") else f"P5\n{width} {height}\n255\n".encode()
    (tmp_path / image).write_bytes(data)
    (tmp_path / "map.yaml").write_text(f"image: {image}\nresolution: 0.05\norigin: [0, 0, 0]\n")
    line = cli_error(capsys, tmp_path, "--world", str(tmp_path / "map.yaml"))
    assert "map.yaml: image:" in line and image in line and f"{width} x {height} pixels" in line
    assert "largest map taken (67108864 pixels" in line


def test_an_albedo_map_larger_than_the_largest_texture_is_one_line(tmp_path, capsys):
    (tmp_path / "skin.png").write_bytes(png_header(20000, 20000))
    painted = (
        '<model name="crate"><static>true</static><pose>5 0 0.5 0 0 0</pose><link name="link"><visual '
        'name="v"><geometry><box><size>1 1 1</size></box></geometry><material><pbr><metal><albedo_map>'
        "skin.png</albedo_map></metal></pbr></material></visual></link></model>"
    )
    line = cli_error(capsys, tmp_path, "--world", str(world_file(tmp_path, "painted.sdf", GROUND, painted)))
    assert "painted.sdf: crate::link/v <albedo_map>:" in line and "skin.png is 20000 x 20000 pixels" in line
    assert "largest texture taken" in line


def test_a_map_reaching_beyond_the_largest_coordinate_is_one_line(tmp_path, capsys):
    Image.fromarray(np.full((100, 100), 254, np.uint8)).save(tmp_path / "room.pgm")
    (tmp_path / "far.yaml").write_text("image: room.pgm\nresolution: 1e8\norigin: [0, 0, 0]\n")
    line = cli_error(capsys, tmp_path, "--world", str(tmp_path / "far.yaml"))
    assert "far.yaml: resolution: 100 x 100 cells of 1e+08 m" in line and "1e+09 m" in line


# --- 5. values MuJoCo refuses, refused where the file is read -------------------------------------------------------


@pytest.mark.parametrize(
    "inertial, field",
    [
        ("<inertial><mass>-1</mass></inertial>", "<inertial><mass> must be positive"),
        (
            "<inertial><mass>1</mass><inertia><ixx>-1</ixx><iyy>1</iyy><izz>1</izz></inertia></inertial>",
            "<inertial><inertia>: a body's inertia must be positive definite",
        ),
        (
            "<inertial><mass>1</mass><inertia><ixx>1</ixx><iyy>1</iyy><izz>5</izz></inertia></inertial>",
            "<inertial><inertia>: principal moments 1, 1, 5 break the triangle inequality",
        ),
    ],
)
def test_a_bad_sdf_inertia_is_one_line_naming_the_file_and_the_model(tmp_path, capsys, inertial, field):
    path = world_file(tmp_path, "inertia.sdf", GROUND, box_model("blk", "1 1 1", "3 0 0.5 0 0 0", False, inertial))
    line = cli_error(capsys, tmp_path, "--world", str(path))
    assert "inertia.sdf: blk::link " in line and field in line and "racecar.xacro" not in line


def test_a_free_model_with_a_one_triangle_mesh_is_one_line_naming_the_file_and_the_model(tmp_path, capsys):
    (tmp_path / "tri.stl").write_text(
        "solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\n"
        "vertex 0 1 0\nendloop\nendfacet\nendsolid t\n"
    )
    sheet = (
        '<model name="sheet"><pose>3 0 0.5 0 0 0</pose><link name="link"><collision name="c"><geometry><mesh>'
        "<uri>tri.stl</uri></mesh></geometry></collision></link></model>"
    )
    line = cli_error(capsys, tmp_path, "--world", str(world_file(tmp_path, "sheet.sdf", GROUND, sheet)))
    assert "sheet.sdf: sheet::link/c <mesh><uri>tri.stl</uri>" in line and "flat" in line
    assert "mesh0" not in line and "racecar.xacro" not in line


def test_mujocos_own_refusal_of_a_world_is_one_line_naming_the_world_and_the_model():
    world = load_world("empty")  # built in Python: nothing read it from a file
    triangle = Mesh(np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]), np.array([[0, 1, 2]], np.int32))
    world.bodies.append(
        WorldBody(
            "sheet::link",
            np.array([3.0, 0.0, 0.5]),
            IDENTITY,
            static=False,
            geoms=[WorldGeom("sheet::link/c", "mesh", (), np.zeros(3), IDENTITY, mesh=triangle)],
        )
    )
    with pytest.raises(RacecarSimError) as error:
        Simulator(world=world, camera=False)
    message = str(error.value)
    assert isinstance(error.value, WorldError) and "\n" not in message
    assert message.startswith("empty (racecar.world): sheet::link/c: MuJoCo cannot take it: ")
    assert "racecar.xacro" not in message and "Element name" not in message


def test_a_track_at_1e300_is_one_line_naming_the_file_line_and_column(tmp_path, capsys):
    (tmp_path / "far.csv").write_text("0,0,1,1\n1e300,0,1,1\n1e300,1e300,1,1\n")
    line = cli_error(capsys, tmp_path, "--world", str(tmp_path / "far.csv"))
    assert "far.csv: line 2: x: 1e+300 m is beyond the largest world coordinate (1e+09 m)" in line


def test_a_1e308_m_wall_height_is_one_line_naming_the_option(tmp_path, capsys):
    (tmp_path / "track.csv").write_text("0,0,1,1\n10,0,1,1\n10,10,1,1\n0,10,1,1\n")
    line = cli_error(capsys, tmp_path, "--world", str(tmp_path / "track.csv"), "--wall-height", "1e308")
    assert "track.csv: wall height (--wall-height)" in line and "got 1e+308" in line


# --- 6. map_server's numbers ----------------------------------------------------------------------------------------


def test_a_map_yaml_with_5e_2_reads_it_as_0_05_as_map_server_does(tmp_path):
    room = np.full((40, 40), 254, np.uint8)
    room[0, :] = 0  # one wall along the top row
    Image.fromarray(room).save(tmp_path / "room.pgm")
    (tmp_path / "map.yaml").write_text(
        "image: room.pgm\nresolution: 5e-2\norigin: [-1e0, -1.0, 0]\noccupied_thresh: 65e-2\n"
    )
    world = load_world(tmp_path / "map.yaml")
    walls = [geom for body in world.bodies if body.name == "map" for geom in body.geoms if geom.collides]
    assert len(walls) == 1 and walls[0].size[:2] == pytest.approx((2.0, 0.05))
