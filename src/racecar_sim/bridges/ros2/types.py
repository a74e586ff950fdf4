"""The ROS 2 message packages no wheel ships, generated for rclpy from the project's own definitions.

ackermann_msgs, tf2_msgs, gazebo_msgs, control_msgs and controller_manager_msgs are built with the rosidl generators
(CMake + a C compiler, as colcon would) into a prefix under the cache, keyed by distro, Python version and the
definitions' contents: ~/.cache/racecar-sim/ros2/<distro>-py<X.Y>-<hash>/. The messages of each package are the sim's
(msgs/definitions: the CDR the bus's messages are serialized to), with the ROS 2 services and the ROS 2 form of the
messages only they use from bridges/ros2/definitions on top. `racecar-sim ros2-env --build` builds it; the bridge
puts it on its ROS side's paths, and `racecar-sim ros2-env` prints them for a user's nodes.

The ROS 2 wheels' CMake files name the include folders of the machine they were built on (/opt/python/cpXY...);
they are read through an overlay prefix (links to the real one, those few files copied with the paths of this
machine), so the installed wheels are never edited.
"""

from __future__ import annotations

import concurrent.futures
import hashlib
import os
import re
import shutil
import subprocess
import tempfile
from collections.abc import Callable
from importlib import resources
from pathlib import Path

from racecar_sim.bridges.ros2.environment import GENERATED, RosPython, cache_root, clean_environment
from racecar_sim.core.errors import ConfigError

PACKAGES = GENERATED
# ROS 1 forms in the sim's definitions that ROS 2 replaces (the ROS 2 ControllerState) or does not have
ROS1_ONLY = frozenset({"controller_manager_msgs/msg/HardwareInterfaceResources.msg"})
BUILD_VERSION = "1"  # bump when the build itself changes what it produces
DONE = "racecar_sim_types.done"  # written last: a prefix without it is not finished
_WHEEL_PATH = re.compile(r"/opt/python/cp\d+-cp\d+t?/")
_PYTHON_INCLUDE = re.compile(r"/opt/python/cp\d+-cp\d+t?/include/python[\d.]+t?")
_NUMPY_INCLUDE = re.compile(r"/opt/python/cp\d+-cp\d+t?/lib/python[\d.]+t?/site-packages/numpy/_?core/include")
GENERATORS = (  # the wheels the build needs besides CMake and g++ (ros-<distro>-<name>; the [ros2] extra's list)
    "rosidl-default-generators", "rosidl-core-generators", "rosidl-typesupport-fastrtps-c",
    "rosidl-typesupport-fastrtps-cpp", "python-cmake-module", "ament-cmake", "ament-cmake-ros",
    "ament-cmake-include-directories", "ament-cmake-gtest", "ament-cmake-gmock", "ament-cmake-pytest", "ament-package",
)  # fmt: skip


def install_generators(distro: str) -> str:
    """The pip command that installs the generators for `distro`'s wheels."""
    return "pip install " + " ".join(f"ros-{distro}-{name}" for name in GENERATORS) + " catkin-pkg"


def _roots() -> tuple[Path, Path]:
    sim = Path(str(resources.files("racecar_sim.msgs").joinpath("definitions")))
    ros2 = Path(__file__).with_name("definitions")
    return sim, ros2


def sources(packages: tuple[str, ...] = PACKAGES) -> dict[str, dict[str, str]]:
    """{package: {"msg/Name.msg" | "srv/Name.srv": text}} of `packages` (every one racecar-sim generates)."""
    sim, ros2 = _roots()
    out: dict[str, dict[str, str]] = {}
    for package in packages:
        files: dict[str, str] = {}
        for root in (sim, ros2):  # the ROS 2 definitions win
            for kind in ("msg", "srv") if root == ros2 else ("msg",):  # the sim's services are ROS 1's (gazebo_ros)
                folder = root / package / kind
                for path in sorted(folder.glob(f"*.{kind}")) if folder.is_dir() else ():
                    rel = f"{kind}/{path.name}"
                    if f"{package}/{rel}" not in ROS1_ONLY:
                        files[rel] = path.read_text(encoding="utf-8")
        out[package] = files
    return out


def _dependencies(package: str, files: dict[str, str]) -> list[str]:
    """The packages a package's definitions name (std_msgs for a Header, geometry_msgs, builtin_interfaces)."""
    found: set[str] = set()
    for text in files.values():
        for line in text.splitlines():
            words = line.split("#", 1)[0].split()
            if len(words) < 2 or "=" in words[1]:  # not a field (a constant, the service's ---)
                continue
            base = words[0].split("[", 1)[0]
            if base == "Header":
                found.add("std_msgs")
            elif "/" in base:
                found.add(base.split("/")[0])
    found.discard(package)
    return sorted(found)


def missing(ros: RosPython) -> tuple[str, ...]:
    """The packages to generate for `ros`: those it cannot import already (a ROS install may have tf2_msgs, ...;
    its own are used, as they are)."""
    return tuple(p for p in PACKAGES if p not in ros.has)


def types_hash(ros: RosPython) -> str:
    """What the prefix is built from: distro, Python, definitions, this build."""
    digest = hashlib.sha256(f"{ros.distro}\0{ros.python_version}\0{BUILD_VERSION}\0".encode())
    for package, files in sorted(sources(missing(ros)).items()):
        for rel, text in sorted(files.items()):
            digest.update(f"{package}/{rel}\0{text}\0".encode())
    return digest.hexdigest()[:12]


def prefix_path(ros: RosPython) -> Path:
    """Where the types of `ros` are (or will be) installed."""
    return cache_root() / f"{ros.distro}-py{ros.python_version}-{types_hash(ros)}"


def built(ros: RosPython) -> Path | None:
    """The finished prefix of `ros`, or None (also when there is nothing to generate for it)."""
    prefix = prefix_path(ros)
    return prefix if (prefix / DONE).is_file() else None


def require(ros: RosPython) -> Path | None:
    """The finished prefix (None if `ros` lacks none of the packages); ConfigError (one line: the command that
    builds it) if it is not built."""
    if not missing(ros):
        return None
    prefix = built(ros)
    if prefix is None:
        raise ConfigError(
            "--ros2: the ROS 2 types racecar-sim generates (ackermann_msgs, tf2_msgs, gazebo_msgs, control_msgs, "
            f"controller_manager_msgs) are not built for {ros.distro} / Python {ros.python_version}: "
            "run `racecar-sim ros2-env --build` once (about a minute)"
        )
    return prefix


# --- the build -----------------------------------------------------------------------------------------------------
def _generator_prefixes(ros: RosPython) -> list[Path]:
    """The prefixes that hold ament_cmake and rosidl_default_generators: the interpreter's own (the wheels) and
    those of a sourced install (AMENT_PREFIX_PATH)."""
    prefixes = [Path(ros.prefix)] + [Path(p) for p in os.environ.get("AMENT_PREFIX_PATH", "").split(os.pathsep) if p]
    return [p for p in dict.fromkeys(prefixes) if p.is_dir()]


def _overlay(prefix: Path, into: Path, python: str) -> Path:
    """`prefix` as CMake may read it: links to everything, and its CMake files that name the wheel builder's include
    folders copied with this machine's (the interpreter's headers, numpy's). `prefix` itself when none do."""
    bad = [p for p in (prefix / "share").glob("*/cmake/*.cmake") if _WHEEL_PATH.search(p.read_text(errors="ignore"))]
    if not bad:
        return prefix
    info = subprocess.run(
        [python, "-c", "import sysconfig, numpy; print(sysconfig.get_paths()['include']); print(numpy.get_include())"],
        env=clean_environment(python),
        capture_output=True,
        text=True,
        check=False,
    )
    lines = info.stdout.split()
    if info.returncode != 0 or len(lines) != 2:
        detail = " ".join(info.stderr.split())[-200:]
        raise ConfigError(f"ros2-env --build: {python} cannot say where its headers and numpy's are: {detail}")
    py_include, np_include = lines
    if os.path.isdir(into):
        shutil.rmtree(into)
    into.mkdir(parents=True)
    for entry in prefix.iterdir():
        if entry.name != "share":
            (into / entry.name).symlink_to(entry)
    bad_packages = {p.parent.parent.name for p in bad}
    (into / "share").mkdir()
    for package in (prefix / "share").iterdir():
        target = into / "share" / package.name
        if package.name not in bad_packages:
            target.symlink_to(package)
            continue
        target.mkdir()
        for entry in package.iterdir():
            if entry.name != "cmake":
                (target / entry.name).symlink_to(entry)
        (target / "cmake").mkdir()
        for entry in (package / "cmake").iterdir():
            if entry in bad:
                text = entry.read_text()
                text = _NUMPY_INCLUDE.sub(np_include, _PYTHON_INCLUDE.sub(py_include, text))
                (target / "cmake" / entry.name).write_text(text)
            else:
                (target / "cmake" / entry.name).symlink_to(entry)
    return into


def _package_files(package: str, files: dict[str, str], deps: list[str]) -> dict[str, str]:
    """package.xml and CMakeLists.txt of one interface package, as `ros2 pkg create` + rosidl would have them."""
    interfaces = " ".join(f'"{rel}"' for rel in sorted(files))
    depends = "".join(f"  <depend>{d}</depend>\n" for d in deps)
    finds = "".join(f"find_package({d} REQUIRED)\n" for d in deps)
    return {
        "package.xml": (
            '<?xml version="1.0"?>\n<package format="3">\n'
            f"  <name>{package}</name>\n  <version>0.0.0</version>\n"
            f"  <description>{package} for racecar-sim's ROS 2 bridge (generated from its definitions)</description>\n"
            '  <maintainer email="racecar-sim@example.com">racecar-sim</maintainer>\n  <license>BSD</license>\n'
            "  <buildtool_depend>ament_cmake</buildtool_depend>\n"
            "  <buildtool_depend>rosidl_default_generators</buildtool_depend>\n"
            f"{depends}"
            "  <exec_depend>rosidl_default_runtime</exec_depend>\n"
            "  <member_of_group>rosidl_interface_packages</member_of_group>\n"
            "  <export><build_type>ament_cmake</build_type></export>\n</package>\n"
        ),
        "CMakeLists.txt": (
            "cmake_minimum_required(VERSION 3.8)\n"
            f"project({package})\n"
            "find_package(ament_cmake REQUIRED)\nfind_package(rosidl_default_generators REQUIRED)\n"
            f"{finds}"
            f"rosidl_generate_interfaces(${{PROJECT_NAME}} {interfaces}"
            + (f" DEPENDENCIES {' '.join(deps)}" if deps else "")
            + ")\nament_export_dependencies(rosidl_default_runtime)\nament_package()\n"
        ),
    }


def build(ros: RosPython, say: Callable[[str], None] = print, jobs: int | None = None) -> Path | None:
    """Generate and compile the packages `ros` lacks into prefix_path(ros) (nothing to do when it is built; None
    when it lacks none). ConfigError, one line, when CMake, a compiler or the rosidl generators are missing, or a
    package fails to build."""
    if not missing(ros):
        return None
    done = built(ros)
    if done is not None:
        return done
    for tool in ("cmake", "c++", "cc"):
        if shutil.which(tool) is None:
            raise ConfigError(f"ros2-env --build needs {tool} on PATH: sudo apt-get install cmake g++")
    generators = [p for p in _generator_prefixes(ros) if (p / "share" / "rosidl_default_generators").is_dir()]
    if not generators or not any((p / "share" / "ament_cmake").is_dir() for p in generators):
        raise ConfigError(
            f"ros2-env --build needs the rosidl generators for {ros.python} ({ros.distro}): "
            + install_generators(ros.distro)
            + " (the [ros2] extra installs them)"
        )
    target = prefix_path(ros)
    target.parent.mkdir(parents=True, exist_ok=True)
    work = Path(tempfile.mkdtemp(prefix=".build-", dir=target.parent))
    try:
        scratch = work / "install"
        read_from = [_overlay(p, work / f"overlay{i}", ros.python) for i, p in enumerate(_generator_prefixes(ros))]
        env = clean_environment(ros.python)
        env["PATH"] = os.pathsep.join([str(Path(ros.python).parent), env.get("PATH", "")])
        search = os.pathsep.join([str(scratch), *map(str, read_from)])
        env["AMENT_PREFIX_PATH"] = env["CMAKE_PREFIX_PATH"] = search
        env.pop("PYTHONPATH", None)
        all_sources = sources(missing(ros))
        names = list(all_sources)
        jobs = jobs or max(1, min(len(names), os.cpu_count() or 1))
        say(f"racecar-sim: building the ROS 2 types ({', '.join(names)}) for {ros.distro} into {target}")
        with concurrent.futures.ThreadPoolExecutor(jobs) as pool:
            futures = {
                pool.submit(_build_package, work, scratch, package, all_sources[package], ros, env): package
                for package in names
            }
            for future in concurrent.futures.as_completed(futures):
                say(f"racecar-sim: built {futures[future]} ({future.result():.0f} s)")
        (scratch / DONE).write_text(f"{ros.distro} {ros.python_version} {types_hash(ros)}\n")
        if target.exists():
            shutil.rmtree(target)
        scratch.rename(target)
    finally:
        shutil.rmtree(work, ignore_errors=True)
    return target


def _build_package(
    work: Path, install: Path, package: str, files: dict[str, str], ros: RosPython, env: dict[str, str]
) -> float:
    import time

    start = time.monotonic()
    src, out = work / "src" / package, work / "build" / package
    for rel, text in {**files, **_package_files(package, files, _dependencies(package, files))}.items():
        (src / rel).parent.mkdir(parents=True, exist_ok=True)
        (src / rel).write_text(text, encoding="utf-8")
    steps = [
        [
            "cmake", "-S", str(src), "-B", str(out), f"-DCMAKE_INSTALL_PREFIX={install}",
            "-DBUILD_TESTING=OFF",  # no build type: -O0 compiles fastest (speed does not matter here)
            f"-DPython3_EXECUTABLE={ros.python}", f"-DPYTHON_EXECUTABLE={ros.python}",
        ],
        ["cmake", "--build", str(out), "-j1"],
        ["cmake", "--install", str(out)],
    ]  # fmt: skip
    for step in steps:
        done = subprocess.run(step, env=env, capture_output=True, text=True, check=False)
        if done.returncode != 0:
            text = done.stdout + done.stderr
            errors = [line for line in text.splitlines() if "error" in line.lower()] or text.splitlines()[-3:]
            detail = " | ".join(errors[:3])[-400:]
            raise ConfigError(f"ros2-env --build: {package}: {' '.join(step[:2])} failed: {detail}")
    return time.monotonic() - start
