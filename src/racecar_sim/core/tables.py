"""Named entries of a YAML table (physics presets, driving profiles) turned into frozen dataclasses."""

from __future__ import annotations

import dataclasses
import math
import typing
from functools import cache
from pathlib import Path
from typing import TYPE_CHECKING, Any, TypeVar

import yaml

from racecar_sim.core import yaml_text
from racecar_sim.core.errors import ConfigError

if TYPE_CHECKING:
    from _typeshed import DataclassInstance

T = TypeVar("T", bound="DataclassInstance")


@cache
def read_table(path: Path) -> dict[str, object]:
    """The YAML mapping of names to entries (or of fields to values) in `path` (read once)."""
    try:
        data = yaml_text.safe_load(path.read_text())
    except (OSError, yaml.YAMLError) as exc:
        raise ConfigError(f"{path}: cannot read: {' '.join(str(exc).split())}") from None
    if not isinstance(data, dict):
        raise ConfigError(f"{path}: expected a mapping of names to entries")
    return data


def table_entry(path: Path, name: str, cls: type[T], kind: str) -> T:
    """Entry `name` of the table as a `cls`; ConfigError names the file, the entry and the known names."""
    table = read_table(path)
    if not isinstance(name, str) or name not in table:
        raise ConfigError(f"unknown {kind} {name!r} (choose from: {', '.join(table)}; {path})")
    entry = table[name]
    where = f"{path}: {kind} '{name}'"
    if not isinstance(entry, dict):
        raise ConfigError(f"{where}: expected a mapping of fields")
    hints = typing.get_type_hints(cls)
    known = {f.name for f in dataclasses.fields(cls)} - {"name"}
    unknown = sorted(set(entry) - known)
    if unknown:
        raise ConfigError(f"{where}: unknown field {', '.join(unknown)}")
    values = {key: checked_value(hints[key], value, f"{where}: {key}") for key, value in entry.items()}
    try:
        return cls(name=name, **values)  # type: ignore[call-arg]  # any dataclass with a `name` field
    except TypeError as exc:
        raise ConfigError(f"{where}: {exc}") from None


def finite_number(value: Any, where: str) -> float:
    """A YAML value as a finite float. PyYAML (YAML 1.1, as rosparam) reads `1e-3` as a string: accept it."""
    number = value
    if isinstance(value, str):
        try:
            number = float(value)
        except ValueError:
            pass
    if isinstance(number, bool) or not isinstance(number, (int, float)) or not math.isfinite(number):
        raise ConfigError(f"{where}: expected a finite number, got {value!r}")
    return float(number)


def checked_value(hint: Any, value: Any, where: str) -> Any:
    """`value` checked against a dataclass field's type hint: float fields take finite numbers, int fields whole
    numbers, str fields strings, dict fields mappings; an optional field (`X | None`) also takes null."""
    args = typing.get_args(hint)
    if type(None) in args:
        if value is None:
            return None
        hint = next(a for a in args if a is not type(None))
    if hint is float:
        return finite_number(value, where)
    if hint is int and (isinstance(value, bool) or not isinstance(value, int)):
        raise ConfigError(f"{where}: expected a whole number, got {value!r}")
    if hint is str and not isinstance(value, str):
        raise ConfigError(f"{where}: expected a string, got {value!r}")
    if typing.get_origin(hint) is dict and not isinstance(value, dict):
        raise ConfigError(f"{where}: expected a mapping, got {value!r}")
    return value


def load_record(path: Path, cls: type[T], overrides: dict[str, object] | None = None) -> T:
    """A flat YAML mapping as a frozen dataclass `cls`, with `overrides` (e.g. from the CLI) applied.

    Every field must be given; float fields must be finite numbers. ConfigError names the file and field.
    """
    data = dict(read_table(path))
    for key, value in (overrides or {}).items():
        if value is not None:
            data[key] = value
    fields = {f.name: f for f in dataclasses.fields(cls)}
    unknown = sorted(set(data) - set(fields))
    missing = sorted(set(fields) - set(data))
    if unknown or missing:
        what = "; ".join(
            filter(
                None,
                [
                    f"unknown field {', '.join(unknown)}" if unknown else None,
                    f"missing field {', '.join(missing)}" if missing else None,
                ],
            )
        )
        raise ConfigError(f"{path}: {what}")
    hints = typing.get_type_hints(cls)
    values = {name: checked_value(hints[name], value, f"{path}: {name}") for name, value in data.items()}
    return cls(**values)
