"""`racecar-sim worlds`: the listing, --show PNGs, and geoms landing where they belong on the map."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from PIL import Image

from racecar_sim.cli.main import main
from racecar_sim.plots import draw_world, world_extent
from racecar_sim.worlds import load_world, world_names

BOX_WORLD = """<sdf version='1.6'><world name='w'><model name='m'><static>true</static><link name='l'>
<collision name='c'><geometry><box><size>1 4 1</size></box></geometry></collision>
<visual name='v'><geometry><box><size>1 4 1</size></box></geometry>
<material><ambient>0 0 1 1</ambient><diffuse>0 0 1 1</diffuse></material></visual>
</link><pose>3 0 0.5 0 0 0</pose></model></world></sdf>"""

# A wall with no visual, turned 90 degrees: it must still show, filled dark grey, along y.
HIDDEN_WALL = """<sdf version='1.6'><world name='w'><model name='m'><static>true</static><pose>0 2 0.5 0 0 1.5708</pose>
<link name='l'><collision name='c'><geometry><box><size>3 0.5 1</size></box></geometry></collision></link>
</model></world></sdf>"""


@pytest.fixture
def box_world(tmp_path):
    path = tmp_path / "box.sdf"
    path.write_text(BOX_WORLD)
    return path


def render(world, limits=(-1.0, 5.0, -3.0, 3.0)):
    """Draw the world on fixed axes; returns the RGBA image and data (x, y) -> (row, column)."""
    fig = Figure(figsize=(6, 6), dpi=100)
    canvas = FigureCanvasAgg(fig)
    ax = fig.add_axes((0.05, 0.05, 0.9, 0.9))
    draw_world(ax, world)
    ax.set_xlim(*limits[:2])
    ax.set_ylim(*limits[2:])
    canvas.draw()
    image = np.asarray(canvas.buffer_rgba())

    def pixel(x: float, y: float) -> np.ndarray:
        px, py = ax.transData.transform((x, y))
        return image[int(round(image.shape[0] - py)), int(round(px))]

    return image, pixel


def test_lists_every_builtin_world(capsys):
    assert main(["worlds"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert [line.split()[0] for line in lines] == world_names()
    assert "spawn 0,0,0" in lines[0] and "150 m ground plane" in lines[0]


def test_listing_through_python_m():
    result = subprocess.run([sys.executable, "-m", "racecar_sim", "worlds"], capture_output=True, text=True, timeout=60)
    assert result.returncode == 0, result.stderr
    assert {line.split()[0] for line in result.stdout.splitlines()} == set(world_names())


def test_show_empty_writes_a_png(tmp_path, capsys):
    out = tmp_path / "tmp" / "x.png"
    assert main(["worlds", "--show", "empty", "--out", str(out)]) == 0
    assert capsys.readouterr().out.strip() == str(out)
    image = Image.open(out)
    assert image.format == "PNG" and image.width >= 800 and image.height >= 600
    assert len(np.unique(np.asarray(image.convert("RGB")).reshape(-1, 3), axis=0)) > 10


def test_only_a_ground_plane_shows_five_metres_around_the_spawn():
    world = load_world("empty")
    assert world_extent(world) == (-5.0, 5.0, -5.0, 5.0)


def test_show_a_file_defaults_to_its_stem_under_runs(box_world, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert main(["worlds", "--show", str(box_world), "--spawn", "3,0,1.05,0"]) == 0  # on the box: checked as run does
    # the path written, not a bare name; under runs/ (ignored by git), never loose in the current folder
    assert capsys.readouterr().out.strip() == str(tmp_path / "runs" / "box.png")
    assert not (tmp_path / "box.png").exists()
    rgb = np.asarray(Image.open(tmp_path / "runs" / "box.png").convert("RGB")).astype(int)
    blue = (rgb[..., 2] > 200) & (rgb[..., 0] < 40) & (rgb[..., 1] < 40)
    assert blue.sum() > 1000


def test_box_and_spawn_land_where_they_belong(box_world):
    _, pixel = render(load_world(box_world))
    assert tuple(pixel(3.0, 0.0)[:3]) == (0, 0, 255)  # the box centre
    assert tuple(pixel(3.0, 1.8)[:3]) == (0, 0, 255)  # 4 m long along y
    assert pixel(1.5, 0.0)[2] > 200 and pixel(1.5, 0.0)[0] > 200  # left of the box (x 2.5 ... 3.5): not blue
    assert pixel(3.0, 2.3)[0] > 200  # beyond its end
    r, g, b, _ = pixel(0.0, 0.0).astype(int)
    assert r > 150 and g < 80 and b < 80  # the spawn mark


def test_collision_geom_without_visual_is_filled_dark_grey(tmp_path):
    path = tmp_path / "hidden.sdf"
    path.write_text(HIDDEN_WALL)
    _, pixel = render(load_world(path))
    r, g, b, _ = pixel(0.0, 2.9).astype(int)  # turned 90 degrees: 3 m along y, from y 0.5 to 3.5
    assert r == g == b and r < 100
    assert pixel(1.2, 2.0)[0] > 200  # only 0.5 m wide along x


def test_missing_world_is_one_line_and_exit_2(capsys):
    assert main(["worlds", "--show", "no_such_world"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "no_such_world" in err
