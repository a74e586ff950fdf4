"""summary.png of a run: the drive on the world map coloured by speed, the last lidar scan, a camera frame, numbers.

A fleet's run (trajectories given as {car name: path}, two or more) draws each car's path in its own colour
(FLEET_COLORS, a legend entry naming the car) instead of by speed; the scan and camera frame are the first car's.

Race marks, where given: the start line (dashed), a cross where each crash started with its sim time, and a diamond
where each lap ended with its number and time (`crashes`, `laps`: {car name: marks with time, x, y, what}).

A fixed size (FIGSIZE at DPI: 1600x1000 px). The map frames the whole world (every geom but the ground planes), the
path and the last scan; the camera frame, the legend and the summary text sit right of it (SIDE), or under it when
the view is long and flat (WIDE, e.g. the tunnel), where the map takes all the height the panel leaves.
Agg only, no pyplot state.
"""

from __future__ import annotations

import textwrap
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Protocol

import numpy as np
import numpy.typing as npt
from matplotlib import colormaps
from matplotlib.artist import Artist
from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.cm import ScalarMappable
from matplotlib.collections import LineCollection
from matplotlib.colors import Normalize
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.transforms import Bbox

from racecar_sim.plots.world_map import draw_world, finite_points, footprints
from racecar_sim.worlds.world import World

FIGSIZE = (16.0, 10.0)  # inches
DPI = 100
TITLE_Y = 0.975
GAP = 0.025  # figure fraction between the panel's items


@dataclass(frozen=True)
class Layout:
    """Where things go, in figure fractions: the map and its colourbar (left, bottom, width, height), and the
    panel holding the camera frame, legend and text, which flows down from `panel` (SIDE) or right (WIDE)."""

    map: tuple[float, float, float, float]
    colorbar: tuple[float, float, float, float]
    panel: tuple[float, float]  # top-left corner
    flow: str  # "down" or "right"
    camera_width: float  # of the camera frame, figure fraction
    camera_height: float  # the most it may take


SIDE = Layout((0.045, 0.065, 0.625, 0.855), (0.677, 0.065, 0.011, 0.855), (0.735, 0.92), "down", 0.25, 0.36)
WIDE = Layout((0.045, 0.45, 0.885, 0.47), (0.94, 0.45, 0.011, 0.47), (0.045, 0.36), "right", 0.3, 0.3)
WIDE_BELOW = 0.55  # routes flatter than this (height over width) get the WIDE layout
WIDE_BOTTOM = 0.03  # figure fraction under the WIDE layout's panel
AXIS_ROOM = 0.075  # figure fraction under the map for its x tick labels and label
TEXT_RIGHT = 0.985  # figure x the summary text (its box's padding included) stays left of
MIN_TEXT_SIZE = 10.0  # points: the summary text is never smaller (1600 px wide PNG); longer lines wrap instead
LABEL_PAD = 2.0  # pixels around a map label that no other label may enter

TRAJECTORY_RATE = 20.0  # Hz, the rows of `trajectory`
TIME_MARK_EVERY = 10.0  # s between the time labels along the path
SPEED_CMAP = "viridis"
PATH_WIDTH = 3.0  # points
HALO = (1.0, 1.0, 1.0, 0.9)  # under the path, so its dark end reads on dark floors too
SCAN_COLOR = "#e7298a"
START_COLOR = "#2ca02c"
# One colour per car of a fleet, in order (repeating after the last): distinct from each other, from the scan's
# magenta and the start marker's green, and readable on light floors and beside dark walls.
FLEET_COLORS = ("#1f77b4", "#ff7f0e", "#9467bd", "#17becf", "#8c564b", "#bcbd22", "#393b79", "#d62728")
VIEW_MARGIN = 0.05  # of the larger side of what is shown, and at least MIN_VIEW_MARGIN
MIN_VIEW_MARGIN = 1.5  # m
MIN_VIEW = 6.0  # m, the smallest side shown (a car that stood still)
# Above draw_world's layers (walls at 2.1, the spawn at 5).
Z_RAYS, Z_HALO, Z_PATH, Z_SCAN, Z_MARKS = 2.5, 3.0, 3.1, 3.5, 6.0
Z_RACE = 6.5  # crash and lap marks, over the time marks
CRASH_COLOR = "#d62728"
LAP_COLOR = "#ffd700"
START_LINE_COLOR = "black"
MAX_LABELS = 12  # labelled marks of each kind per car; more are drawn unlabelled
LABEL_SPACING = 0.03  # of the map's width: a mark nearer than this to a labelled one is drawn unlabelled


class Mark(Protocol):
    """A crash or a lap end: sim time (s), where the car was (m), and what (the thing hit, or the lap's number and
    time)."""

    @property
    def time(self) -> float: ...
    @property
    def x(self) -> float: ...
    @property
    def y(self) -> float: ...
    @property
    def what(self) -> str: ...


Trajectories = np.ndarray | Mapping[str, np.ndarray]
Marks = Mapping[str, Sequence[Mark]]


def save_summary(
    path: str | Path,
    world: World,
    trajectory: Trajectories,
    *,
    scan_origin: np.ndarray | None = None,
    scan_points: np.ndarray | None = None,
    camera_bgr: np.ndarray | None = None,
    title: str = "",
    lines: Sequence[str] = (),
    rate: float = TRAJECTORY_RATE,
    crashes: Marks | None = None,
    laps: Marks | None = None,
    start_line: tuple[tuple[float, float], tuple[float, float]] | None = None,
) -> Path:
    """Write the run's summary PNG (1600x1000 px) and return its path; see summary_figure for the arguments."""
    fig, _ = summary_figure(
        world,
        trajectory,
        scan_origin=scan_origin,
        scan_points=scan_points,
        camera_bgr=camera_bgr,
        title=title,
        lines=lines,
        rate=rate,
        crashes=crashes,
        laps=laps,
        start_line=start_line,
    )
    path = Path(path)
    fig.savefig(path, format="png", dpi=DPI)
    return path


def summary_figure(
    world: World,
    trajectory: Trajectories,
    *,
    scan_origin: np.ndarray | None = None,
    scan_points: np.ndarray | None = None,
    camera_bgr: np.ndarray | None = None,
    title: str = "",
    lines: Sequence[str] = (),
    rate: float = TRAJECTORY_RATE,
    crashes: Marks | None = None,
    laps: Marks | None = None,
    start_line: tuple[tuple[float, float], tuple[float, float]] | None = None,
) -> tuple[Figure, Axes]:
    """The summary figure (not attached to pyplot) and its map Axes.

    trajectory: (N, 3) x, y (m, world frame) and ground speed (m/s), row i at i / rate s (a long run's RunLog keeps
    fewer rows: its trajectory_rate), the last row the end of the path; or a fleet's
    {car name: (N, 3)}, each car drawn in its own colour (one entry is drawn as the single car's path).
    scan_origin: (x, y) of the laser; scan_points: (M, 2) world end points of the finite beams.
    camera_bgr: (H, W, 3) uint8 BGR image. lines: summary text, one item a line. Scan and camera may be None.
    crashes, laps: {car name: marks} (the single car's under any name); start_line: its two ends (x, y).
    """
    paths = (
        {name: _checked(path) for name, path in trajectory.items()}
        if isinstance(trajectory, Mapping)
        else {"": _checked(trajectory)}
    )
    fleet = len(paths) > 1
    traj = np.vstack(list(paths.values())) if paths else np.zeros((0, 3))
    origin = None if scan_origin is None else np.asarray(scan_origin, dtype=float).reshape(-1)[:2]
    points = np.zeros((0, 2)) if scan_points is None else np.asarray(scan_points, dtype=float).reshape(-1, 2)
    image = None if camera_bgr is None else _camera_rgb(camera_bgr)

    prints = footprints(world)
    lo, hi = _view_bounds(np.vstack([finite_points(prints), _view_points(traj, origin, points, world)]))
    layout = WIDE if (hi[1] - lo[1]) < WIDE_BELOW * (hi[0] - lo[0]) else SIDE
    if fleet and layout is SIDE:  # no speed colourbar: the panel (a wider table) starts where it would be
        layout = Layout(**{**vars(SIDE), "panel": (SIDE.colorbar[0] + 0.01, SIDE.panel[1])})
    fig = Figure(figsize=FIGSIZE, dpi=DPI)
    canvas = FigureCanvasAgg(fig)
    fig.suptitle(title or world.name, x=0.045, y=TITLE_Y, ha="left", fontsize=16, fontweight="bold")
    ax = fig.add_axes(layout.map)
    draw_world(ax, world, prints)
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_axisbelow(True)
    ax.grid(True, color=(0.3, 0.3, 0.3), alpha=0.35, linewidth=0.5)
    _set_view(ax, lo, hi)

    handles: list[Line2D] = []
    if origin is not None and len(points):
        handles.append(_draw_scan(ax, origin, points, next(iter(paths)) if fleet else ""))
    colorbar_axes = None
    if fleet:
        handles = _draw_fleet(ax, paths) + handles
    else:
        norm = Normalize(0.0, max(float(traj[:, 2].max()) if len(traj) else 0.0, 0.1))
        handles = _draw_trajectory(ax, traj, norm, rate) + handles
        colorbar_axes = fig.add_axes(layout.colorbar)
        colorbar = fig.colorbar(ScalarMappable(norm=norm, cmap=SPEED_CMAP), cax=colorbar_axes)
        colorbar.set_label("speed (m/s)")
    handles += _draw_race(ax, crashes or {}, laps or {}, start_line, fleet)
    owner = f"{next(iter(paths))}'s " if fleet else ""
    if layout.flow == "right":  # the panel at the bottom as tall as it needs to be, the map above it in the rest
        _, lowest = _fill_panel(fig, canvas, layout, image, handles, lines, owner, remove=True)
        panel_top = WIDE_BOTTOM + (layout.panel[1] - lowest)
        _fill_panel(
            fig, canvas, Layout(**{**vars(layout), "panel": (layout.panel[0], panel_top)}), image, handles, lines, owner
        )
        left, _, width, _ = layout.map
        bottom = panel_top + AXIS_ROOM
        height = layout.map[1] + layout.map[3] - bottom
        ax.set_position((left, bottom, width, height))
        if colorbar_axes is not None:
            colorbar_axes.set_position((layout.colorbar[0], bottom, layout.colorbar[2], height))
        _set_view(ax, lo, hi)
    else:
        _fill_panel(fig, canvas, layout, image, handles, lines, owner)
    _drop_overlapping_labels(ax, canvas)
    return fig, ax


def _drop_overlapping_labels(ax: Axes, canvas: FigureCanvasAgg) -> None:
    """Leave out every map label that would overlap one kept before it, as drawn at the final size: the spawn's
    first, then the crash and lap labels, then the time marks along the path (each kind's own spacing cannot see
    the others, nor a fleet's labels that land together on screen)."""
    renderer = canvas.get_renderer()
    labels = [t for t in ax.texts if t.get_text()]
    labels.sort(key=lambda t: (not t.get_text().startswith("spawn ("), -t.get_zorder()))
    kept: list[Bbox] = []
    for text in labels:
        box = text.get_window_extent(renderer).padded(LABEL_PAD)
        if any(box.overlaps(other) for other in kept):
            text.remove()
        else:
            kept.append(box)


def _wrapped(lines: Sequence[str], width: int) -> list[str]:
    """Lines longer than `width` characters broken at spaces, continued under the value column (a summary line is
    a 17-character label, then its value)."""
    out: list[str] = []
    for line in lines:
        out += textwrap.wrap(line, width, subsequent_indent=" " * 17, break_on_hyphens=False) or [line]
    return out


def _checked(trajectory: np.ndarray) -> np.ndarray:
    traj = np.asarray(trajectory, dtype=float)
    if traj.size == 0:
        return np.zeros((0, 3))
    if traj.ndim != 2 or traj.shape[1] != 3:
        raise ValueError(f"trajectory must be (N, 3) x, y, speed; got shape {traj.shape}")
    return traj


def fleet_color(index: int) -> str:
    """The colour of the fleet's car number `index` (0 for the first)."""
    return FLEET_COLORS[index % len(FLEET_COLORS)]


def _fill_panel(
    fig: Figure,
    canvas: FigureCanvasAgg,
    layout: Layout,
    image: np.ndarray | None,
    handles: list[Line2D],
    lines: Sequence[str],
    owner: str = "",
    remove: bool = False,
) -> tuple[list[Artist], float]:
    """The camera frame, the legend and the text box, one after the other from the panel's corner (`canvas`: the
    figure's). Returns what it drew and the lowest figure y it reached; `remove`: take it all off again (a
    measurement)."""
    renderer = canvas.get_renderer()
    x, top = layout.panel
    to_figure = fig.transFigure.inverted()
    drawn: list[Artist] = []
    lowest = top

    def advance(extent: Bbox) -> None:  # move past an item drawn at (x, top)
        nonlocal x, top, lowest
        box = extent.transformed(to_figure)
        lowest = min(lowest, box.y0)
        if layout.flow == "down":
            top = box.y0 - GAP
        else:
            x = box.x1 + GAP

    if image is not None:
        width = min(
            layout.camera_width, layout.camera_height * image.shape[1] / image.shape[0] * FIGSIZE[1] / FIGSIZE[0]
        )
        height = width * image.shape[0] / image.shape[1] * FIGSIZE[0] / FIGSIZE[1]
        title_room = 0.03
        cam = fig.add_axes((x, top - title_room - height, width, height))
        _draw_camera(cam, image, f"{owner}camera, last frame")
        drawn.append(cam)
        extent = cam.get_tightbbox(renderer)
        assert extent is not None, "a visible axes has a bounding box"
        advance(extent)
    if handles:
        legend = fig.legend(
            handles=handles,
            loc="upper left",
            bbox_to_anchor=(x, top),
            frameon=False,
            fontsize=11,
            handlelength=2.2,
            borderaxespad=0.0,
            borderpad=0.0,
        )
        drawn.append(legend)
        advance(legend.get_window_extent(renderer))
    if lines:
        text = fig.text(
            x + 0.006,
            top - 0.01,
            "\n".join(lines),
            ha="left",
            va="top",
            family="monospace",
            fontsize=11,
            linespacing=1.5,
            bbox={"boxstyle": "round,pad=0.6", "facecolor": (0.96, 0.96, 0.96), "edgecolor": (0.7, 0.7, 0.7)},
        )
        drawn.append(text)
        for _ in range(3):  # long lines (a crash's wall name, a fleet's table): a smaller font, inside the figure
            box = text.get_window_extent(renderer).transformed(to_figure)
            if box.x1 <= TEXT_RIGHT:
                break
            size = text.get_fontsize() * (TEXT_RIGHT - box.x0) / (box.x1 - box.x0) * 0.98
            text.set_fontsize(max(size, MIN_TEXT_SIZE))
        box = text.get_window_extent(renderer).transformed(to_figure)
        if box.x1 > TEXT_RIGHT:  # still too wide at the smallest legible size: wrap the long lines
            width = max(int(max(map(len, lines)) * (TEXT_RIGHT - box.x0) / (box.x1 - box.x0)) - 1, 20)
            text.set_text("\n".join(_wrapped(lines, width)))
        lowest = min(lowest, text.get_window_extent(renderer).transformed(to_figure).y0 - 0.012)  # the box's pad
    if remove:
        for artist in drawn:
            artist.remove()
    return drawn, lowest


def _view_points(traj: np.ndarray, origin: np.ndarray | None, points: np.ndarray, world: World) -> np.ndarray:
    """The points the map must show besides the world's geoms: the spawn, the path and the scan."""
    parts: list[npt.ArrayLike] = [[[world.spawn.x, world.spawn.y]], traj[:, :2], points]
    parts += [origin[None]] if origin is not None else []
    xy = np.vstack(parts)
    return xy[np.all(np.isfinite(xy), axis=1)]


def _view_bounds(xy: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Lower and upper corners of the points plus a margin, at least MIN_VIEW a side."""
    lo, hi = xy.min(axis=0), xy.max(axis=0)
    margin = max(MIN_VIEW_MARGIN, VIEW_MARGIN * float((hi - lo).max()))
    centre, half = (lo + hi) / 2, np.maximum((hi - lo) / 2 + margin, MIN_VIEW / 2)
    return centre - half, centre + half


def _set_view(ax: Axes, lo: np.ndarray, hi: np.ndarray) -> None:
    """Show lo..hi, widened about the centre to the Axes' own shape, so equal aspect fills the whole box."""
    box = ax.get_position(original=True)  # the rectangle asked for, before any aspect shrinking
    shape = box.height * FIGSIZE[1] / (box.width * FIGSIZE[0])  # y extent over x extent that fills the box
    half = (hi - lo) / 2
    half = np.maximum(half, [half[1] / shape, half[0] * shape])
    centre = (lo + hi) / 2
    ax.set_xlim(centre[0] - half[0], centre[0] + half[0])
    ax.set_ylim(centre[1] - half[1], centre[1] + half[1])
    ax.set_aspect("equal", adjustable="box")  # the limits already fit the box


def _draw_trajectory(ax: Axes, traj: np.ndarray, norm: Normalize, rate: float = TRAJECTORY_RATE) -> list[Line2D]:
    """The path as segments coloured by speed over a white halo, start and end markers, a label every 10 s."""
    if not len(traj):
        return []
    xy = traj[:, :2]
    if len(traj) >= 2:
        ax.plot(
            xy[:, 0],
            xy[:, 1],
            color=HALO,
            linewidth=PATH_WIDTH + 2.5,
            solid_capstyle="round",
            solid_joinstyle="round",
            zorder=Z_HALO,
        )
        segments = np.stack([xy[:-1], xy[1:]], axis=1)
        speed = (traj[:-1, 2] + traj[1:, 2]) / 2
        ax.add_collection(
            LineCollection(
                list(segments),
                array=speed,
                cmap=SPEED_CMAP,
                norm=norm,
                linewidths=PATH_WIDTH,
                capstyle="round",
                joinstyle="round",
                zorder=Z_PATH,
            ),
            autolim=False,
        )
    step = max(round(TIME_MARK_EVERY * rate), 1)
    for i in range(step, len(traj) - step // 4, step):  # none right before the end marker
        ax.plot(*xy[i], "o", color="white", markeredgecolor="black", markersize=4, zorder=Z_MARKS)
        ax.annotate(
            f"{i / rate:g} s",
            xy[i],
            xytext=(5, 5),
            textcoords="offset points",
            fontsize=8,
            zorder=Z_MARKS,
            bbox={"boxstyle": "round,pad=0.15", "facecolor": "white", "alpha": 0.7, "linewidth": 0},
        )
    (start,) = ax.plot(
        *xy[0],
        "o",
        color=START_COLOR,
        markeredgecolor="white",
        markeredgewidth=1.5,
        markersize=11,
        zorder=Z_MARKS,
        label="start",
    )
    (end,) = ax.plot(
        *xy[-1],
        "s",
        color="black",
        markeredgecolor="white",
        markeredgewidth=1.5,
        markersize=10,
        zorder=Z_MARKS,
        label="end",
    )
    assert norm.vmax is not None, "the caller's norm has its upper limit"
    mid = float(norm.vmax) / 2
    path = Line2D([], [], color=_cmap_color(norm, mid), linewidth=PATH_WIDTH, label="path, coloured by speed")
    return [path, start, end]


def _draw_fleet(ax: Axes, paths: Mapping[str, np.ndarray]) -> list[Line2D]:
    """Each car's path in its own colour over a white halo, a start circle and an end square in that colour; the
    legend names the cars."""
    handles = []
    for index, (name, traj) in enumerate(paths.items()):
        color = fleet_color(index)
        handles.append(Line2D([], [], color=color, linewidth=PATH_WIDTH, label=name))
        if not len(traj):
            continue
        xy = traj[:, :2]
        if len(traj) >= 2:
            ax.plot(
                xy[:, 0],
                xy[:, 1],
                color=HALO,
                linewidth=PATH_WIDTH + 2.5,
                solid_capstyle="round",
                solid_joinstyle="round",
                zorder=Z_HALO,
            )
            ax.plot(
                xy[:, 0],
                xy[:, 1],
                color=color,
                linewidth=PATH_WIDTH,
                solid_capstyle="round",
                solid_joinstyle="round",
                zorder=Z_PATH,
            )
        ax.plot(*xy[0], "o", color=color, markeredgecolor="white", markeredgewidth=1.5, markersize=10, zorder=Z_MARKS)
        ax.plot(*xy[-1], "s", color=color, markeredgecolor="black", markeredgewidth=1.0, markersize=9, zorder=Z_MARKS)
    start = Line2D(
        [],
        [],
        marker="o",
        linestyle="",
        color="0.55",
        markeredgecolor="white",
        markeredgewidth=1.5,
        markersize=10,
        label="start",
    )
    end = Line2D(
        [],
        [],
        marker="s",
        linestyle="",
        color="0.55",
        markeredgecolor="black",
        markeredgewidth=1.0,
        markersize=9,
        label="end",
    )
    return handles + [start, end]


def _draw_race(
    ax: Axes,
    crashes: Marks,
    laps: Marks,
    start_line: tuple[tuple[float, float], tuple[float, float]] | None,
    fleet: bool,
) -> list[Line2D]:
    """The start line, a cross at each crash (labelled with its sim time, and in a fleet the car) and a diamond at
    each lap's end (its number and lap time); their legend entries."""
    handles: list[Line2D] = []
    if start_line is not None:
        (ax_, ay), (bx, by) = start_line
        ax.plot([ax_, bx], [ay, by], color="white", linewidth=4.0, zorder=Z_MARKS - 0.1, solid_capstyle="butt")
        ax.plot([ax_, bx], [ay, by], color=START_LINE_COLOR, linewidth=2.0, linestyle=(0, (3, 2)), zorder=Z_MARKS)
        handles.append(Line2D([], [], color=START_LINE_COLOR, linewidth=2.0, linestyle=(0, (3, 2)), label="start line"))
    style = {"boxstyle": "round,pad=0.15", "facecolor": "white", "alpha": 0.8, "linewidth": 0}
    crash_style = {"marker": "X", "color": CRASH_COLOR, "markeredgecolor": "white", "markeredgewidth": 1.2}
    lap_style = {"marker": "D", "color": LAP_COLOR, "markeredgecolor": "black", "markeredgewidth": 1.0}
    near = LABEL_SPACING * float(np.ptp(ax.get_xlim()))  # a label this close to another one is left out
    labelled: list[tuple[float, float]] = []

    def label(mark: Mark, text: str, offset: tuple[float, float], color: str) -> None:
        if any(abs(mark.x - x) < near and abs(mark.y - y) < near for x, y in labelled):
            return
        labelled.append((mark.x, mark.y))
        ax.annotate(
            text,
            (mark.x, mark.y),
            xytext=offset,
            textcoords="offset points",
            fontsize=8,
            color=color,
            zorder=Z_RACE,
            bbox=style,
        )

    for marks, mark_style, size, legend in (
        (laps, lap_style, 9, "lap ended (lap time)"),
        (crashes, crash_style, 12, "crash (sim time)"),
    ):
        if not any(marks.values()):
            continue
        for car, kept in marks.items():
            prefix = f"{car} " if fleet else ""
            for k, mark in enumerate(kept):
                ax.plot(mark.x, mark.y, linestyle="", markersize=size, zorder=Z_RACE, **mark_style)  # type: ignore[arg-type]
                if k >= MAX_LABELS:
                    continue
                if marks is laps:
                    label(mark, f"{prefix}lap {mark.what}", (6, -12), "black")
                else:
                    label(mark, f"{prefix}crash {mark.time:.2f} s", (7, 6), CRASH_COLOR)
        handles.append(Line2D([], [], linestyle="", markersize=size - 1, label=legend, **mark_style))  # type: ignore[arg-type]
    return handles


def _cmap_color(norm: Normalize, value: float) -> tuple[float, float, float, float]:
    return colormaps[SPEED_CMAP](norm(value))


def _draw_scan(ax: Axes, origin: np.ndarray, points: np.ndarray, owner: str = "") -> Line2D:
    """The last scan from the laser: faint rays and the points they hit."""
    rays = np.stack([np.broadcast_to(origin, points.shape), points], axis=1)
    ax.add_collection(
        LineCollection(list(rays), colors=SCAN_COLOR, linewidths=0.5, alpha=0.18, zorder=Z_RAYS), autolim=False
    )
    ax.scatter(points[:, 0], points[:, 1], s=5, color=SCAN_COLOR, linewidths=0, zorder=Z_SCAN)
    label = f"last lidar scan ({len(points)} hits)"
    return Line2D(
        [], [], marker="o", linestyle="", color=SCAN_COLOR, markersize=5, label=f"{owner}'s {label}" if owner else label
    )


def _camera_rgb(camera_bgr: np.ndarray) -> np.ndarray:
    """The camera's BGR image as RGB; ValueError unless it is (H, W, 3) uint8."""
    image = np.asarray(camera_bgr)
    if image.ndim != 3 or image.shape[2] != 3 or image.dtype != np.uint8:
        raise ValueError(f"camera_bgr must be an (H, W, 3) uint8 BGR image, got {image.shape} {image.dtype}")
    return image[..., ::-1]


def _draw_camera(ax: Axes, rgb: np.ndarray, title: str = "camera, last frame") -> None:
    """The camera frame, top row up, in a thin frame."""
    ax.imshow(rgb, interpolation="antialiased")
    ax.set_xticks([])
    ax.set_yticks([])
    for spine in ax.spines.values():
        spine.set_linewidth(0.8)
        spine.set_edgecolor((0.3, 0.3, 0.3))
    ax.set_title(title, fontsize=11, loc="left")
