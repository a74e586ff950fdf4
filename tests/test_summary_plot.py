"""summary.png: a real PNG of fixed size with the path drawn where it belongs, the camera frame, with or without
the sensors."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from matplotlib import colormaps
from PIL import Image

from racecar_sim.plots import world_figure
from racecar_sim.plots.summary import DPI, FIGSIZE, MIN_TEXT_SIZE, SPEED_CMAP, save_summary, summary_figure
from racecar_sim.plots.world_map import footprint
from racecar_sim.worlds import load_world

SIZE = (round(FIGSIZE[0] * DPI), round(FIGSIZE[1] * DPI))  # 1600x1000
TOP_BGR, BOTTOM_BGR = (200, 30, 10), (10, 200, 30)  # the camera frame's halves, BGR
PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


@pytest.fixture(scope="module")
def walker():
    return load_world("walker")


def circle_drive(n: int = 1200, centre=(-2.0, 6.0), radius: float = 5.0) -> np.ndarray:
    """n samples at 20 Hz round a circle, the speed ramping from 0.5 to 3 m/s."""
    angle = np.linspace(0.0, 1.8 * math.pi, n)
    return np.c_[centre[0] + radius * np.cos(angle), centre[1] + radius * np.sin(angle), np.linspace(0.5, 3.0, n)]


def camera_frame() -> np.ndarray:
    frame = np.empty((480, 640, 3), np.uint8)
    frame[:240], frame[240:] = TOP_BGR, BOTTOM_BGR
    return frame


def scan_around(origin: np.ndarray, radius: float = 3.0, beams: int = 270) -> np.ndarray:
    angle = np.linspace(-0.75 * math.pi, 0.75 * math.pi, beams)
    return origin + radius * np.c_[np.cos(angle), np.sin(angle)]


def read_png(path) -> np.ndarray:
    assert path.read_bytes()[:8] == PNG_SIGNATURE
    with Image.open(path) as image:
        assert image.format == "PNG"
        assert image.size == SIZE
        return np.asarray(image.convert("RGB")).astype(int)


def pixels_like(rgb: np.ndarray, color, tol: int = 6) -> np.ndarray:
    """(row, col) of the pixels within tol of an RGB colour."""
    return np.argwhere(np.abs(rgb - np.asarray(color)).max(axis=2) <= tol)


def assert_path_drawn(rgb: np.ndarray, ax, trajectory: np.ndarray, rows: list[int]) -> None:
    """Each sampled row of the trajectory is drawn in its speed's colour (within 2 px of where it maps)."""
    ax.figure.canvas.draw()
    cmap, vmax = colormaps[SPEED_CMAP], trajectory[:, 2].max()
    for i in rows:
        x, y = ax.transData.transform(trajectory[i, :2])
        col, row = int(round(x)), int(round(SIZE[1] - y))
        patch = rgb[row - 2 : row + 3, col - 2 : col + 3].reshape(-1, 3)
        expected = np.array(cmap(trajectory[i, 2] / vmax)[:3]) * 255
        assert np.abs(patch - expected).max(axis=1).min() < 12, (i, expected, patch)


def test_summary_shows_path_scan_and_camera(tmp_path, walker):
    trajectory = circle_drive()
    origin = trajectory[-1, :2]
    kwargs = {
        "scan_origin": origin,
        "scan_points": scan_around(origin),
        "camera_bgr": camera_frame(),
        "title": "walker run",
        "lines": ["distance   28.3 m", "mean speed 1.75 m/s"],
    }
    path = save_summary(tmp_path / "summary.png", walker, trajectory, **kwargs)
    assert path == tmp_path / "summary.png"
    rgb = read_png(path)
    assert len(np.unique(rgb.reshape(-1, 3), axis=0)) > 100

    # The camera frame, turned RGB and upright: its top half above its bottom half, no BGR colour left over.
    top, bottom = pixels_like(rgb, TOP_BGR[::-1]), pixels_like(rgb, BOTTOM_BGR[::-1])
    assert len(top) > 20_000 and len(bottom) > 20_000
    assert top[:, 0].max() < bottom[:, 0].min()
    assert len(pixels_like(rgb, TOP_BGR)) == 0 and len(pixels_like(rgb, BOTTOM_BGR)) == 0

    _, ax = summary_figure(walker, trajectory, **kwargs)  # the same figure, for its data-to-pixel transform
    assert_path_drawn(rgb, ax, trajectory, [100, 300, 500, 700, 900])
    scan_pixels = pixels_like(rgb, (0xE7, 0x29, 0x8A), tol=10)  # the scan's points
    assert len(scan_pixels) > 200
    # The view holds the whole path and scan.
    (x0, x1), (y0, y1) = ax.get_xlim(), ax.get_ylim()
    shown = np.vstack([trajectory[:, :2], scan_around(origin)])
    assert np.all((shown[:, 0] > x0) & (shown[:, 0] < x1) & (shown[:, 1] > y0) & (shown[:, 1] < y1))
    assert_frames_the_world(ax, walker)
    assert (x1 - x0) < 55 and (y1 - y0) < 40  # the whole of walker (32 m x 29 m) with margins, no more


def test_summary_without_lidar_or_camera(tmp_path):
    """A straight run along the tunnel (the wide layout), no scan, no camera."""
    tunnel = load_world("tunnel")
    n = 1200
    trajectory = np.c_[np.linspace(0.0, 60.0, n), np.full(n, -0.8), np.linspace(0.2, 2.0, n)]
    path = save_summary(tmp_path / "summary.png", tunnel, trajectory, lines=["distance 60.0 m"])
    rgb = read_png(path)
    _, ax = summary_figure(tunnel, trajectory, lines=["distance 60.0 m"])
    assert_path_drawn(rgb, ax, trajectory, [100, 300, 500, 700, 900, 1100])
    assert len(pixels_like(rgb, (0xE7, 0x29, 0x8A), tol=10)) == 0


def assert_frames_the_world(ax, world) -> None:
    """Every geom but the ground planes lies inside the Axes' limits (the whole world is shown)."""
    (x0, x1), (y0, y1) = ax.get_xlim(), ax.get_ylim()
    shown = 0
    for body, geom in world.geoms():
        if geom.kind == "plane":
            continue
        xy = footprint(body, geom).xy
        assert np.all((xy[:, 0] >= x0) & (xy[:, 0] <= x1) & (xy[:, 1] >= y0) & (xy[:, 1] <= y1)), (
            geom.name,
            xy.min(axis=0),
            xy.max(axis=0),
            (x0, x1, y0, y1),
        )
        shown += 1
    assert shown > 0


def room_map(folder: Path) -> Path:
    """A ROS map: a 12 m x 10 m room (walls 0.2 m thick) from (-2, -5), a pillar inside; the spawn at the origin."""
    cells = np.full((200, 240), 254, np.uint8)  # 0.05 m cells, row 0 at the top (y = 5 m)
    cells[:4], cells[-4:], cells[:, :4], cells[:, -4:] = 0, 0, 0, 0
    cells[40:80, 100:110] = 0
    Image.fromarray(cells).save(folder / "room.pgm")
    (folder / "room.yaml").write_text(
        "image: room.pgm\nresolution: 0.05\norigin: [-2.0, -5.0, 0.0]\nnegate: 0\n"
        "occupied_thresh: 0.65\nfree_thresh: 0.196\n"
    )
    return folder / "room.yaml"


@pytest.mark.parametrize("name", ["map", "tunnel"])
def test_summary_and_world_map_frame_the_whole_world(tmp_path, name):
    """A short drive near the spawn still shows every wall: the map's bottom wall, the tunnel's far arms."""
    world = load_world(room_map(tmp_path) if name == "map" else "tunnel")
    n = 200
    if name == "map":  # 1 m along the room's middle, far from its bottom wall
        trajectory = np.c_[np.linspace(0.0, 1.0, n), np.zeros(n), np.full(n, 1.0)]
    else:  # 10 m down the corridor from the spawn
        trajectory = np.c_[np.linspace(0.0, 10.0, n), np.full(n, -0.8), np.full(n, 1.0)]
    origin = trajectory[-1, :2]
    scan = scan_around(origin, radius=1.5)
    _, ax = summary_figure(world, trajectory, scan_origin=origin, scan_points=scan)
    assert_frames_the_world(ax, world)
    (x0, x1), (y0, y1) = ax.get_xlim(), ax.get_ylim()
    assert np.all((scan[:, 0] > x0) & (scan[:, 0] < x1) & (scan[:, 1] > y0) & (scan[:, 1] < y1))
    _, ax = world_figure(world)  # racecar-sim worlds --show
    assert_frames_the_world(ax, world)


def test_summary_of_a_car_that_never_moved(tmp_path, walker):
    rgb = read_png(save_summary(tmp_path / "summary.png", walker, np.zeros((0, 3))))
    assert rgb.std() > 10


def test_bad_trajectory_or_camera_frame(tmp_path, walker):
    with pytest.raises(ValueError, match=r"\(N, 3\).*\(10, 2\)"):
        save_summary(tmp_path / "summary.png", walker, np.zeros((10, 2)))
    with pytest.raises(ValueError, match=r"\(480, 640\)"):
        save_summary(tmp_path / "summary.png", walker, circle_drive(), camera_bgr=np.zeros((480, 640), np.uint8))
    assert not (tmp_path / "summary.png").exists()


class _Mark:
    """A crash or lap mark as the run log gives them."""

    def __init__(self, time: float, x: float, y: float, what: str) -> None:
        self.time, self.x, self.y, self.what = time, x, y, what


def test_map_labels_never_overlap_and_the_text_stays_legible():
    """A fleet whose cars crash close together (as the tunnel fleet does), with the spawn label among them and a
    summary line far wider than the panel: every label drawn clears every other, and the text is at least
    MIN_TEXT_SIZE points (wrapped to fit) inside the figure."""
    tunnel = load_world("tunnel")
    x0, y0 = tunnel.spawn.x, tunnel.spawn.y
    paths = {
        f"car{k}": np.c_[np.linspace(x0, x0 + 20.0, 200), np.full(200, y0 + 0.3 * k), np.ones(200)] for k in (1, 2, 3)
    }
    near = [(2.0 * k, 0.25 * k) for k in range(6)]  # crashes 2 m apart: their labels, 4 m long here, would pile up
    crashes = {
        car: [_Mark(14.1 + i, x0 + 1.0 + dx, y0 + dy, "car3") for i, (dx, dy) in enumerate(near)] for car in paths
    }
    long_line = "car1 crashes     4: " + "; ".join(f"{t:.2f} s MIT_Tunnel::Wall_{t:.0f}" for t in (14.1, 15.3, 16.3))
    fig, ax = summary_figure(tunnel, paths, crashes=crashes, lines=["distance 76.9 m", long_line])
    renderer = fig.canvas.get_renderer()
    boxes = [t.get_window_extent(renderer) for t in ax.texts if t.get_text()]
    assert any("crash" in t.get_text() for t in ax.texts) and any("spawn" in t.get_text() for t in ax.texts)
    for i, a in enumerate(boxes):
        assert not any(a.overlaps(b) for b in boxes[i + 1 :]), "two labels overlap"
    (text,) = [t for t in fig.texts if "distance 76.9 m" in t.get_text()]
    assert text.get_fontsize() >= MIN_TEXT_SIZE
    box = text.get_window_extent(renderer).transformed(fig.transFigure.inverted())
    assert box.x1 <= 1.0 and "MIT_Tunnel::Wall_16" in text.get_text()  # wrapped, not cut
