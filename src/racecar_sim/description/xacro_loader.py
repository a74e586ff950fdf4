"""Expand xacro files with the PyPI `xacro` package, no ROS install needed; `$(find pkg)` goes through
ROS_PACKAGE_PATH (then the packages racecar-sim ships), as rospack resolves it. The shipped car's own includes
stay its own, so that a user's racecar_description on the path changes the user's car, not the default one."""

from __future__ import annotations

import contextlib
import io
import sys
from collections.abc import Iterator, Mapping
from pathlib import Path
from typing import TextIO

from racecar_sim.core.errors import DescriptionError, RacecarSimError
from racecar_sim.description import xacro_cache
from racecar_sim.description.ros_packages import SHIPPED_ROOTS, PackageNotFound, find_package
from racecar_sim.description.urdf import Robot, parse_urdf

_DATA = Path(__file__).resolve().parent / "data"  # the package is installed as files (importlib.resources: ~5 ms)
DEFAULT_XACRO = _DATA / "racecar_description" / "urdf" / "racecar.xacro"


def package_path(package: str) -> Path:
    """The folder of a package racecar-sim ships (its own defaults, whatever ROS_PACKAGE_PATH holds: read at
    import time, they must not depend on the user's path); `find_package` is what `$(find package)` uses."""
    for root in SHIPPED_ROOTS:
        if (root / package / "package.xml").is_file():
            return root / package
    raise DescriptionError(
        f"package '{package}': racecar-sim ships no such package (in {', '.join(map(str, SHIPPED_ROOTS))})"
    )


def _shipped_package_of(path: Path) -> Path | None:
    """The shipped package folder a file lies in, or None for a user's file."""
    path = path.resolve()
    for root in SHIPPED_ROOTS:
        if path.is_relative_to(root):
            parts = path.relative_to(root).parts
            return root / parts[0] if len(parts) > 1 else None
    return None


def _find(package: str, asker: str) -> str:
    """`$(find package)` asked by the file `asker`."""
    own = _shipped_package_of(Path(asker))
    if own is not None and own.name == package:
        return str(own)  # the shipped car's own includes stay its own, whatever the user's path shadows
    return str(find_package(package, needed_by=asker))


class _PackageFinder:
    """Stands in for xacro's `$(find)` (ament_index_python, not on PyPI) with rospack's crawl; keeps the first
    PackageNotFound, which xacro would otherwise wrap into a message of its own, and every answer (for the cache)."""

    def __init__(self, top: Path) -> None:
        self.top = top
        self.error: PackageNotFound | None = None
        self.found: xacro_cache.Finds = []

    def __call__(self, package: str) -> str:
        import xacro

        asker = str(xacro.filestack[-1] if getattr(xacro, "filestack", None) and xacro.filestack[-1] else self.top)
        try:
            folder = _find(package, asker)
        except PackageNotFound as exc:
            self.error = self.error or exc
            raise
        self.found.append((package, asker, folder))
        return folder

    @contextlib.contextmanager
    def installed(self) -> Iterator[None]:
        import xacro.substitution_args as substitution_args

        original = substitution_args._eval_find
        substitution_args._eval_find = self
        try:
            yield
        finally:
            substitution_args._eval_find = original


class _Said:
    """Whether xacro (or a warning) wrote anything to stdout or stderr while watching; what it writes goes through."""

    def __init__(self) -> None:
        self.anything = False

    @contextlib.contextmanager
    def watching(self) -> Iterator[None]:
        streams = sys.stdout, sys.stderr
        sys.stdout, sys.stderr = (_Tee(stream, self) for stream in streams)
        try:
            yield
        finally:
            sys.stdout, sys.stderr = streams


class _Tee(io.TextIOBase):
    def __init__(self, stream: TextIO, said: _Said) -> None:
        self.stream, self.said = stream, said

    def write(self, text: str) -> int:
        self.said.anything = self.said.anything or bool(text)
        return self.stream.write(text)

    def flush(self) -> None:
        self.stream.flush()

    def isatty(self) -> bool:
        return self.stream.isatty()


def expand_xacro(path: str | Path = DEFAULT_XACRO, args: Mapping[str, str] | None = None) -> str:
    """Expand a xacro file (with `xacro:arg` mappings) to a URDF string (kept on disk: xacro_cache.py)."""
    path = Path(path)
    if not path.is_file():
        raise DescriptionError(f"{path}: xacro file not found")
    mappings = {k: str(v) for k, v in (args or {}).items()}
    kept = xacro_cache.lookup(path, mappings, _find)
    if kept is not None:
        return kept
    import xacro  # ~30 ms with its YAML: only when nothing is kept

    finder = _PackageFinder(path)
    first_read = len(xacro.all_includes)
    said = _Said()
    try:
        with finder.installed(), said.watching():
            doc = xacro.process_file(str(path), mappings=dict(mappings))  # xacro adds to the dict it is given
    except RacecarSimError:
        raise
    except Exception as exc:  # xacro raises XacroException, XML errors, NameError, ...
        if finder.error is not None:
            raise finder.error from None
        message = " ".join(str(exc).split())
        raise DescriptionError(f"{path}: xacro expansion failed: {message}") from None
    text = doc.toprettyxml(indent="  ")
    if not said.anything:  # an expansion that warned is not kept: the next run warns again
        xacro_cache.store(path, mappings, text, map(str, xacro.all_includes[first_read:]), finder.found)
    return text


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
