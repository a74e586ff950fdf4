"""The sweep's results table: one row per episode, written as results.csv and, with pyarrow, results.parquet."""

from __future__ import annotations

import csv
import importlib.util
import json
import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

CSV = "results.csv"
PARQUET = "results.parquet"
PARAM_PREFIX = "param_"  # one column per driver parameter: param_distance, param_speed, ...
LEADING = ["index", "world", "driver", "seed"]
MEASURES = [
    "duration",
    "sim_time",
    "wall_time",
    "real_time_factor",
    "distance",
    "mean_speed",
    "min_clearance",
    "collisions",
    "first_collision_time",
    "laps",
    "best_lap",
    "final_x",
    "final_y",
    "final_yaw",
    "folder",
    "error",
]


def table_columns(rows: Sequence[dict[str, Any]], param_names: Sequence[str]) -> dict[str, list[Any]]:
    """The rows (sorted by index) as named columns: LEADING, a param_ column per parameter (None where a driver
    does not take it), then MEASURES. A parameter value that is a list (a sector) is its JSON text."""
    rows = sorted(rows, key=lambda row: row["index"])
    columns: dict[str, list[Any]] = {name: [row.get(name) for row in rows] for name in LEADING}
    for name in param_names:
        columns[PARAM_PREFIX + name] = [_cell(row["params"].get(name)) for row in rows]
    for name in MEASURES:
        columns[name] = [row.get(name) for row in rows]
    return columns


def write_table(rows: Sequence[dict[str, Any]], param_names: Sequence[str], out: str | Path) -> list[Path]:
    """results.csv (and results.parquet when pyarrow is installed) in `out`; returns the paths written."""
    out = Path(out)
    columns = table_columns(rows, param_names)
    names = list(columns)
    written = [out / CSV]
    with open(written[0], "w", newline="") as f:
        writer = csv.writer(f)
        writer.writerow(names)
        for values in zip(*columns.values()):
            writer.writerow(["" if _missing(v) else v for v in values])
    if importlib.util.find_spec("pyarrow") is not None:
        import pyarrow as pa
        import pyarrow.parquet as pq

        table = pa.table({name: _arrow_column(pa, values) for name, values in columns.items()})
        pq.write_table(table, out / PARQUET)
        written.append(out / PARQUET)
    return written


def _cell(value: Any) -> Any:
    if isinstance(value, (list, tuple, dict)):
        return json.dumps(list(value) if isinstance(value, tuple) else value)
    return value


def _arrow_column(pa: Any, values: list[Any]) -> Any:
    """One Parquet column; a parameter given as numbers for one driver and as text for another becomes text."""
    values = [None if _missing(v) else v for v in values]
    try:
        return pa.array(values)
    except (pa.ArrowInvalid, pa.ArrowTypeError):
        return pa.array([None if v is None else str(v) for v in values])


def _missing(value: Any) -> bool:
    return value is None or (isinstance(value, float) and math.isnan(value))
