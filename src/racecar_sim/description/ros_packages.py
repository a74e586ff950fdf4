"""ROS package lookup as rospack and gazebo_ros do it: `$(find pkg)`, `package://pkg/...` and `model://name`.

A package is a folder holding a package.xml (its <name> names it). `find_package` crawls the folders of
ROS_PACKAGE_PATH first, in order (rospkg's crawl: the first folder that has a package wins, a package's own
sub-folders are not searched, CATKIN_IGNORE hides a tree), then the folders of packages racecar-sim ships.
Model folders for `model://` come from GAZEBO_MODEL_PATH (and Gazebo's newer variables), from each package's
`<export><gazebo_ros gazebo_model_path="${prefix}/..."/>` and from the folders that hold the packages, so that
`model://racecar_description/models/MIT_Tunnel` finds the package's own models folder.
"""

from __future__ import annotations

import functools
import os
import xml.etree.ElementTree as ET
from collections.abc import Iterable
from pathlib import Path
from typing import TYPE_CHECKING

from racecar_sim.core.errors import ConfigError

if TYPE_CHECKING:  # rospkg (and its minidom) is imported by the first crawl: a run of the shipped car makes none
    import rospkg

_PACKAGE_ROOT = Path(__file__).resolve().parent.parent
SHIPPED_ROOTS: tuple[Path, ...] = (_PACKAGE_ROOT / "description" / "data", _PACKAGE_ROOT / "launch" / "data")
PACKAGE_PATH_VARIABLE = "ROS_PACKAGE_PATH"
MODEL_PATH_VARIABLES = ("GAZEBO_MODEL_PATH", "GZ_SIM_RESOURCE_PATH", "SDF_PATH")
FIX = "give the folder that holds it with --package-path DIR or ROS_PACKAGE_PATH"

_crawls: dict[tuple[str, ...], rospkg.RosPack] = {}


class PackageNotFound(ConfigError):
    """A `$(find pkg)` or `package://pkg` names a package that is neither on the package path nor shipped."""


def _env_paths(variable: str) -> list[Path]:
    return [Path(p) for p in os.environ.get(variable, "").split(os.pathsep) if p]


def _crawl(roots: Iterable[Path], fresh: bool = False) -> rospkg.RosPack:
    """A rospkg crawl of `roots`, kept while the roots stay the same (a fresh one on request)."""
    import rospkg

    key = tuple(str(r) for r in roots)
    if fresh or key not in _crawls:
        crawl = rospkg.RosPack(ros_paths=[k for k in key if os.path.isdir(k)])
        try:
            crawl.list()  # crawls now: a broken package.xml is reported here, not half-way through a later lookup
        except rospkg.InvalidManifest as exc:
            raise ConfigError(
                f"{' '.join(str(exc).split())} (fix that package.xml, or take its folder off ROS_PACKAGE_PATH)"
            ) from None
        _crawls[key] = crawl
    return _crawls[key]


def _lookup(name: str, roots: tuple[Path, ...]) -> Path | None:
    import rospkg

    for fresh in (False, True):  # a package made since the last crawl of the same path is found on a second look
        try:
            return Path(_crawl(roots, fresh).get_path(name))
        except rospkg.ResourceNotFound:
            continue
    return None


def find_package(name: str, needed_by: str | Path | None = None) -> Path:
    """The folder of package `name`: ROS_PACKAGE_PATH first, then the packages racecar-sim ships.

    needed_by: the file that asks (named in the PackageNotFound message)."""
    found = _lookup(name, tuple(_env_paths(PACKAGE_PATH_VARIABLE))) or _lookup(name, SHIPPED_ROOTS)
    if found is None:
        asker = f"{needed_by}: " if needed_by else ""
        where = os.environ.get(PACKAGE_PATH_VARIABLE) or "(ROS_PACKAGE_PATH is empty)"
        raise PackageNotFound(
            f"{asker}package '{name}' not found on ROS_PACKAGE_PATH {where} nor among the "
            f"packages racecar-sim ships: {FIX}"
        )
    return found


def resolve_uri(uri: str, base_dir: Path | None = None, needed_by: str | Path | None = None) -> Path:
    """A file named by `package://pkg/rest`, `model://name/rest`, `file:///abs` or a plain path (relative to
    `base_dir`, else to the working folder)."""
    uri = uri.strip()
    if uri.startswith("package://"):
        package, _, rest = uri[len("package://") :].partition("/")
        return find_package(package, needed_by) / rest
    if uri.startswith("model://"):
        model, _, rest = uri[len("model://") :].partition("/")
        for folder in gazebo_model_dirs():
            if (folder / model).is_dir():
                return folder / model / rest
        asker = f"{needed_by}: " if needed_by else ""
        raise ConfigError(
            f"{asker}{uri}: model '{model}' not found in any model folder (add its folder to "
            "GAZEBO_MODEL_PATH or --model-path, or its package with --package-path)"
        )
    if uri.startswith("file://"):
        uri = uri[len("file://") :]
    elif "://" in uri:
        asker = f"{needed_by}: " if needed_by else ""
        raise ConfigError(f"{asker}{uri}: only package://, model://, file:// and plain paths are supported")
    path = Path(uri)
    return path if path.is_absolute() or base_dir is None else Path(base_dir) / path


def package_folders() -> list[Path]:
    """Every package folder found on ROS_PACKAGE_PATH, those of its first folder first."""
    roots = tuple(_env_paths(PACKAGE_PATH_VARIABLE))
    if not roots:
        return []
    crawl = _crawl(roots)
    folders = sorted(Path(crawl.get_path(name)) for name in crawl.list())
    absolute = [Path(os.path.abspath(r)) for r in roots]
    return sorted(folders, key=lambda f: next((i for i, r in enumerate(absolute) if f.is_relative_to(r)), len(roots)))


def _gazebo_exports(package: Path) -> tuple[Path, ...]:
    """The gazebo_model_path exports of a package.xml, `${prefix}` being the package folder."""
    try:
        return _read_exports(package, (package / "package.xml").stat().st_mtime_ns)
    except OSError:
        return ()  # the crawl already read it; a file gone since adds no folders


@functools.lru_cache(maxsize=1024)
def _read_exports(package: Path, mtime_ns: int) -> tuple[Path, ...]:
    try:
        root = ET.parse(package / "package.xml").getroot()
    except (OSError, ET.ParseError):
        return ()
    paths = []
    for export in root.findall("export/gazebo_ros"):
        for entry in (export.get("gazebo_model_path") or "").split(os.pathsep):
            if entry.strip():
                paths.append(Path(entry.strip().replace("${prefix}", str(package))))
    return tuple(paths)


def gazebo_model_dirs() -> list[Path]:
    """Folders that hold model:// models, in search order: GAZEBO_MODEL_PATH (GZ_SIM_RESOURCE_PATH, SDF_PATH),
    the gazebo_ros exports of the packages on ROS_PACKAGE_PATH, and the folders holding those packages."""
    dirs: list[Path] = []
    for variable in MODEL_PATH_VARIABLES:
        dirs += _env_paths(variable)
    packages = package_folders()
    for package in packages:
        dirs += _gazebo_exports(package)
    dirs += [package.parent for package in packages]
    unique: list[Path] = []
    for d in dirs:
        d = Path(os.path.normpath(d))
        if d not in unique:
            unique.append(d)
    return unique


def _prepend(variable: str, dirs: Iterable[str | Path]) -> None:
    new = [str(Path(d).resolve()) for d in dirs]
    old = [p for p in os.environ.get(variable, "").split(os.pathsep) if p and p not in new]
    if new:
        os.environ[variable] = os.pathsep.join(new + old)


def add_package_path(dirs: Iterable[str | Path]) -> None:
    """Put folders first on ROS_PACKAGE_PATH (ROS processes started later inherit it); a folder that does not
    exist is a ConfigError."""
    dirs = list(dirs)
    for d in dirs:
        if not Path(d).is_dir():
            raise ConfigError(f"--package-path {d}: no such folder (give a folder that holds ROS packages)")
    _prepend(PACKAGE_PATH_VARIABLE, dirs)


def add_model_path(dirs: Iterable[str | Path]) -> None:
    """Put folders first on GAZEBO_MODEL_PATH."""
    _prepend(MODEL_PATH_VARIABLES[0], dirs)
