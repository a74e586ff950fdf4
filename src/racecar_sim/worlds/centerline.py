"""Race tracks as worlds: a closed centerline CSV (x, y, w_right, w_left per row) walled along both borders.

The format of the F1TENTH racetrack database: metres, comma (or semicolon) separated, with an optional header
row, plain (`x,y,w_right,w_left`) or a `#` comment (`# x_m,y_m,w_tr_right_m,w_tr_left_m`) whose names place
the columns. The last point joins the first; a last row repeating the first point is dropped. Borders are the
centerline moved w_left to the left and w_right to the right (averaged normals), simplified to within
BORDER_TOLERANCE. The loaded World keeps the centerline (World.centerline, with its widths). The CSV reader here
(read_csv_table) also reads pure-pursuit paths (drivers/waypoints.py) and a built-in world's centerline
(read_course_line: walker's).
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import numpy as np

from racecar_sim.core.errors import RacecarSimError, WorldError
from racecar_sim.worlds.walls import border_walls, offset_polyline, simplify
from racecar_sim.worlds.world import MAX_COORDINATE, Centerline, Spawn, World, WorldBody, WorldGeom

COLUMNS = ("x", "y", "w_right", "w_left")
BORDER_TOLERANCE = 0.01  # m, a simplified border stays this close to the offset centerline
WALL_THICKNESS = 0.1  # m


def load_track(path: str | Path, wall_height: float) -> World:
    """The track at `path` on Gazebo's ground plane, walls outside both borders, the car on the first point."""
    from racecar_sim.worlds.catalog import load_world  # catalog imports this module lazily

    path = Path(path)
    points, w_right, w_left, line_numbers = read_centerline(path)
    geoms: list[WorldGeom] = []
    borders = []
    sides: tuple[tuple[Literal["left", "right"], np.ndarray], ...] = (("left", w_left), ("right", w_right))
    for side, widths in sides:
        try:
            border = offset_polyline(points, widths, side, closed=True)
            _warn_if_folded(path, points, border, side, line_numbers)
            border = simplify(border, BORDER_TOLERANCE, closed=True)
            borders.append(border)
            geoms += border_walls(border, True, side, WALL_THICKNESS, wall_height, name=f"{side}_wall")
        except ValueError as exc:  # a centerline that doubles back, or a border that collapses to a point
            raise WorldError(f"{path}: {exc}") from None
    world = load_world("empty")
    world.name, world.source = path.stem, str(path)
    world.bodies.append(WorldBody("track", np.zeros(3), np.array([1.0, 0.0, 0.0, 0.0]), static=True, geoms=geoms))
    world.cover_ground(np.concatenate(borders))
    (x0, y0), (x1, y1) = points[:2]
    world.spawn = Spawn(float(x0), float(y0), Spawn().z, math.atan2(y1 - y0, x1 - x0))
    world.centerline = Centerline(points, True, str(path), np.column_stack([w_right, w_left]))
    return world


def read_course_line(path: Path) -> Centerline:
    """A built-in world's centerline from its CSV (x, y columns named in the header): a loop when the last row
    repeats the first."""
    table = read_csv_table(path, WorldError)
    x, y = table.find(X_NAMES), table.find(Y_NAMES)
    if x is None or y is None:
        raise WorldError(f"{path}: the header names no x and y columns")
    points = table.numbers([(x, "x"), (y, "y")])
    return Centerline(points, len(points) > 2 and bool(np.array_equal(points[0], points[-1])), str(path))


def _warn_if_folded(path: Path, points: np.ndarray, border: np.ndarray, side: str, line_numbers: list[int]) -> None:
    """A warning where a border runs backwards: the width exceeds the turn's radius and its walls cross the track."""
    forward = np.einsum("ij,ij->i", np.roll(points, -1, axis=0) - points, np.roll(border, -1, axis=0) - border)
    if np.any(forward <= 0):
        line = line_numbers[int(np.flatnonzero(forward <= 0)[0])]
        warnings.warn(
            f"{path}: line {line}: the {side} border folds over itself (w_{side} exceeds the turn "
            "radius), so its walls cross the track",
            stacklevel=2,
        )


def read_centerline(path: Path) -> tuple[np.ndarray, np.ndarray, np.ndarray, list[int]]:
    """Points (N, 2), w_right (N,), w_left (N,) and their CSV line numbers, checked; errors name file and line.

    Columns are found by the header's names when it names x and y (x_m, y_m, w_tr_right_m, w_tr_left_m),
    else they are the first four in the order x, y, w_right, w_left. A file without width columns (a
    raceline, a waypoint list) is refused in one line that says to use it as a pure-pursuit --path.
    """
    table = read_csv_table(path, WorldError)
    first = table.lines[0] if table.lines else None
    x, y = table.find(X_NAMES), table.find(Y_NAMES)
    if x is not None and y is not None:
        right, left = table.find(W_RIGHT_NAMES), table.find(W_LEFT_NAMES)
        if right is None or left is None:
            raise table.fail(
                table.header_line,
                f"no track-width columns (w_tr_right_m, w_tr_left_m) in the header "
                f"({', '.join(table.header or ())}): {PATH_HINT}",
            )
        indices = [x, y, right, left]
    elif table.rows and table.width != len(COLUMNS):
        kind = DELIMITER_NAMES.get(table.delimiter, repr(table.delimiter))
        hint = f": {PATH_HINT}" if table.width < len(COLUMNS) else ""
        raise table.fail(
            first, f"expected {len(COLUMNS)} {kind}-separated columns ({', '.join(COLUMNS)}), got {table.width}{hint}"
        )
    else:
        indices = list(range(len(COLUMNS)))
    values = table.numbers(list(zip(indices, COLUMNS))).reshape(-1, 4)
    rows = list(table.lines)
    for row, line in zip(values, rows):
        for name, value in zip(COLUMNS, row):
            if abs(value) > MAX_COORDINATE:
                raise table.fail(
                    line, f"{name}: {value:g} m is beyond the largest world coordinate ({MAX_COORDINATE:g} m)"
                )
        for name, value in zip(COLUMNS[2:], row[2:]):
            if value <= 0:
                raise table.fail(line, f"{name}: track width must be positive, got {value:g}")
    points, w_right, w_left = values[:, :2], values[:, 2], values[:, 3]
    if len(points) > 1 and np.array_equal(points[0], points[-1]):
        points, w_right, w_left, rows = points[:-1], w_right[:-1], w_left[:-1], rows[:-1]
    if len(points) < 3:
        raise WorldError(f"{path}: a closed track needs at least 3 centerline points, got {len(points)}")
    step = np.hypot(*(np.roll(points, -1, axis=0) - points).T)
    if np.any(step == 0):
        i = int(np.flatnonzero(step == 0)[0])
        raise WorldError(f"{path}: line {rows[(i + 1) % len(rows)]}: repeats the point of line {rows[i]}")
    return points, w_right, w_left, rows


# --- CSV tables: the reader shared with drivers/waypoints.py ----------------------------------------------------

# Column names (lower case) that mean each quantity, in the F1TENTH / TUM formats and plain spellings.
X_NAMES = ("x", "x_m")
Y_NAMES = ("y", "y_m")
W_RIGHT_NAMES = ("w_right", "w_right_m", "w_tr_right", "w_tr_right_m", "wr")
W_LEFT_NAMES = ("w_left", "w_left_m", "w_tr_left", "w_tr_left_m", "wl")
SPEED_NAMES = ("speed", "speed_mps", "v", "v_mps", "vx", "vx_mps", "velocity")
DELIMITER_NAMES = {",": "comma", ";": "semicolon"}
# A raceline (or waypoint list) has no widths to wall: it is a path. Said when one is given as a world.
PATH_HINT = (
    "a path without track widths is not a world: use it as --path FILE with --driver pure-pursuit, on a "
    "world with walls (for an F1TENTH raceline, its <Track>_map.yaml)"
)


@dataclass(frozen=True)
class CsvTable:
    """A CSV file's data rows as text fields, their line numbers, and the header's column names if it has one.

    The delimiter is `;` if the first non-comment line holds one, else `,`. The header is a first non-comment
    line with no number in it (`x,y,w_right,w_left`), or else the last `#` line before the data when it has
    as many fields as the rows and none is a number (`# x_m,y_m,w_tr_right_m,w_tr_left_m`). Other `#` lines,
    text after a `#` on a data line, and blank lines are comments. Every row has as many fields as the first
    (or the header).
    """

    path: Path
    delimiter: str
    header: tuple[str, ...] | None  # as written, stripped
    header_line: int | None
    rows: list[list[str]]
    lines: list[int]
    error: type[RacecarSimError]

    @property
    def width(self) -> int:
        """Number of columns."""
        return len(self.header) if self.header is not None else len(self.rows[0]) if self.rows else 0

    def find(self, names: tuple[str, ...]) -> int | None:
        """Index of the header column called one of `names` (case-insensitive); None without a header or match."""
        if self.header is None:
            return None
        lowered = [h.lower() for h in self.header]
        return next((lowered.index(n) for n in names if n in lowered), None)

    def fail(self, line: int | None, message: str) -> RacecarSimError:
        """The table's error class with a one-line message naming the file (and the line)."""
        where = f"{self.path}: line {line}: " if line is not None else f"{self.path}: "
        return self.error(where + " ".join(message.split()))

    def numbers(self, columns: list[tuple[int, str]]) -> np.ndarray:
        """(N, K) floats of the columns (index, name for errors), row by row; each must be a finite number."""
        out = np.empty((len(self.rows), len(columns)))
        for i, (row, line) in enumerate(zip(self.rows, self.lines)):
            for j, (index, name) in enumerate(columns):
                field = row[index]
                try:
                    value = float(field)
                except ValueError:
                    raise self.fail(line, f"{name}: not a number: {field!r}") from None
                if not math.isfinite(value):
                    raise self.fail(line, f"{name}: must be finite, got {field}")
                out[i, j] = value
        return out


def read_csv_table(path: str | Path, error: type[RacecarSimError] = WorldError) -> CsvTable:
    """Read a track or path CSV into a CsvTable (see there); `error` is raised, one line, naming file and line."""
    path = Path(path)
    try:
        lines = path.read_text(encoding="utf-8-sig").splitlines()
    except (OSError, UnicodeDecodeError) as exc:
        reason = exc.strerror if isinstance(exc, OSError) and exc.strerror else exc
        raise error(f"{path}: cannot read: {reason}") from None
    comment: tuple[int, str] | None = None  # the last `#` line before the first non-comment line
    delimiter: str | None = None
    header: tuple[str, ...] | None = None
    header_line: int | None = None
    rows: list[list[str]] = []
    numbers: list[int] = []
    for n, line in enumerate(lines, start=1):
        text = line.strip()
        if text.startswith("#"):
            if delimiter is None:
                comment = (n, text.lstrip("#"))
            continue
        text = text.split("#", 1)[0].strip()
        if not text:
            continue
        if delimiter is None:
            delimiter = ";" if ";" in text else ","
        fields = [f.strip().strip('"').strip() for f in text.split(delimiter)]
        if not rows and header is None and not any(_is_number(f) for f in fields):
            header, header_line = tuple(fields), n  # a plain header row
            continue
        expected = len(header) if header is not None else len(rows[0]) if rows else len(fields)
        if len(fields) != expected:
            kind = DELIMITER_NAMES.get(delimiter, repr(delimiter))
            first = f"the header (line {header_line})" if header is not None else f"line {numbers[0]}"
            raise error(f"{path}: line {n}: {len(fields)} {kind}-separated columns, {first} has {expected}")
        rows.append(fields)
        numbers.append(n)
    if header is None and comment is not None and rows:
        fields = [f.strip() for f in comment[1].split(delimiter)]
        if len(fields) == len(rows[0]) and all(fields) and not any(_is_number(f) for f in fields):
            header, header_line = tuple(fields), comment[0]
    return CsvTable(path, delimiter or ",", header, header_line, rows, numbers, error)


def _is_number(field: str) -> bool:
    try:
        float(field)
    except ValueError:
        return False
    return True
