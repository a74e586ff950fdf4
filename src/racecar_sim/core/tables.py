"""Named entries of a YAML table (physics presets, driving profiles) turned into frozen dataclasses."""

from __future__ import annotations

from functools import lru_cache
from pathlib import Path
from typing import TypeVar

import yaml

from racecar_sim.core.errors import ConfigError

T = TypeVar("T")


@lru_cache(maxsize=None)
def read_table(path: Path) -> dict[str, dict]:
    """The YAML mapping of names to entries in `path` (read once)."""
    try:
        data = yaml.safe_load(path.read_text())
    except (OSError, yaml.YAMLError) as exc:
        raise ConfigError(f"{path}: cannot read: {' '.join(str(exc).split())}") from None
    if not isinstance(data, dict):
        raise ConfigError(f"{path}: expected a mapping of names to entries")
    return data


def table_entry(path: Path, name: str, cls: type[T], kind: str) -> T:
    """Entry `name` of the table as a `cls`; ConfigError names the file, the entry and the known names."""
    table = read_table(path)
    if name not in table:
        raise ConfigError(f"unknown {kind} '{name}' (choose from: {', '.join(table)}; {path})")
    try:
        return cls(name=name, **table[name])  # type: ignore[call-arg]
    except TypeError as exc:
        raise ConfigError(f"{path}: {kind} '{name}': {exc}") from None


def load_record(path: Path, cls: type[T], overrides: dict[str, object] | None = None) -> T:
    """A flat YAML mapping as a frozen dataclass `cls`, with `overrides` (e.g. from the CLI) applied.

    Every field must be given; float fields must be finite numbers. ConfigError names the file and field.
    """
    import dataclasses
    import math

    data = dict(read_table(path))
    for key, value in (overrides or {}).items():
        if value is not None:
            data[key] = value
    fields = {f.name: f for f in dataclasses.fields(cls)}  # type: ignore[arg-type]
    unknown = sorted(set(data) - set(fields))
    missing = sorted(set(fields) - set(data))
    if unknown or missing:
        what = "; ".join(filter(None, [unknown and f"unknown field {', '.join(unknown)}",
                                       missing and f"missing field {', '.join(missing)}"]))
        raise ConfigError(f"{path}: {what}")
    values = {}
    for name, value in data.items():
        if fields[name].type in ("float", float):
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
                raise ConfigError(f"{path}: {name}: expected a finite number, got {value!r}")
            value = float(value)
        values[name] = value
    return cls(**values)
