"""Expand the shipped xacro files with the PyPI `xacro` package, no ROS install needed."""

from __future__ import annotations

import contextlib
from collections.abc import Iterator, Mapping
from importlib import resources
from pathlib import Path

import xacro
import xacro.substitution_args as substitution_args

from racecar_sim.core.errors import DescriptionError
from racecar_sim.description.urdf import Robot, parse_urdf

_DATA = Path(str(resources.files("racecar_sim.description") / "data"))
DEFAULT_XACRO = _DATA / "racecar_description" / "urdf" / "racecar.xacro"


def package_path(package: str) -> Path:
    """Where `$(find package)` points: the package's own data folder."""
    path = _DATA / package
    if not path.is_dir():
        raise DescriptionError(f"$(find {package}): no such package in {_DATA}")
    return path


@contextlib.contextmanager
def _find_from_package_data() -> Iterator[None]:
    # xacro resolves $(find) through ament_index_python, which is not on PyPI.
    original = substitution_args._eval_find
    substitution_args._eval_find = lambda pkg: str(package_path(pkg))
    try:
        yield
    finally:
        substitution_args._eval_find = original


def expand_xacro(path: str | Path = DEFAULT_XACRO, args: Mapping[str, str] | None = None) -> str:
    """Expand a xacro file (with `xacro:arg` mappings) to a URDF string."""
    path = Path(path)
    if not path.is_file():
        raise DescriptionError(f"{path}: xacro file not found")
    mappings = {k: str(v) for k, v in (args or {}).items()}
    try:
        with _find_from_package_data():
            doc = xacro.process_file(str(path), mappings=mappings)
    except DescriptionError:
        raise
    except Exception as exc:  # xacro raises XacroException, XML errors, NameError, ...
        message = " ".join(str(exc).split())
        raise DescriptionError(f"{path}: xacro expansion failed: {message}") from None
    return doc.toprettyxml(indent="  ")


def load_robot(path: str | Path = DEFAULT_XACRO, args: Mapping[str, str] | None = None) -> Robot:
    """Expand a xacro (or read a plain .urdf) file and parse it into a `Robot`."""
    path = Path(path)
    if path.suffix == ".urdf":
        try:
            text = path.read_text()
        except OSError as exc:
            raise DescriptionError(f"{path}: cannot read URDF: {exc.strerror}") from None
    else:
        text = expand_xacro(path, args)
    return parse_urdf(text, source=str(path))
