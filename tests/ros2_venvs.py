"""Virtual environments with the ROS 2 wheels for the ROS 2 bridge's tests: one per distro, made once.

Each holds rclpy on Fast DDS and the message packages the wheels ship (the Jazzy one also the rosidl generators, so
`racecar-sim ros2-env --build` can generate ackermann_msgs, tf2_msgs, gazebo_msgs, ... for it). They live under
$RACECAR_SIM_TEST_CACHE (default ~/.cache/racecar-sim/test-venvs), keyed by distro, Python version and package list,
and are made by the first test that needs them or ahead of time by CI: `python tests/ros2_venvs.py [jazzy kilted]`
(which also builds the generated types for Jazzy). A test skips only when the package registry cannot be reached.
"""

from __future__ import annotations

import fcntl
import hashlib
import os
import subprocess
import sys
import venv
from pathlib import Path

from racecar_sim.bridges.ros2.types import GENERATORS

RUNTIME = (
    "rclpy", "rmw-fastrtps-cpp", "std-msgs", "sensor-msgs", "nav-msgs", "geometry-msgs", "rosgraph-msgs", "std-srvs",
)  # fmt: skip
PACKAGES = {
    "jazzy": [f"ros-jazzy-{p}" for p in RUNTIME + GENERATORS] + ["catkin-pkg"],
    "kilted": [f"ros-kilted-{p}" for p in RUNTIME],
}
PYTHONS = ("3.11", "3.12")  # the Python versions the ROS 2 wheels are built for
_UNREACHABLE = (
    "Failed to establish a new connection",
    "Temporary failure in name resolution",
    "Name or service not known",
    "Max retries exceeded",
    "Network is unreachable",
    "Connection refused",
    "ConnectionError",
    "ReadTimeoutError",
)


class RegistryUnreachable(RuntimeError):
    """pip could not reach the package registry."""


def cache_root() -> Path:
    """$RACECAR_SIM_TEST_CACHE, else ~/.cache/racecar-sim/test-venvs."""
    given = os.environ.get("RACECAR_SIM_TEST_CACHE")
    return Path(given) if given else Path.home() / ".cache" / "racecar-sim" / "test-venvs"


def python_version() -> str:
    return f"{sys.version_info[0]}.{sys.version_info[1]}"


def venv_path(distro: str) -> Path:
    key = hashlib.sha256(" ".join(PACKAGES[distro]).encode()).hexdigest()[:10]
    return cache_root() / f"{distro}-py{python_version()}-{key}"


def ros_venv(distro: str) -> Path:
    """The venv's python for `distro`, made now if needed. RegistryUnreachable when pip cannot reach the registry;
    RuntimeError for any other failure (with pip's last lines)."""
    if python_version() not in PYTHONS:
        raise RuntimeError(f"the ROS 2 wheels are built for Python {' and '.join(PYTHONS)}, not {python_version()}")
    path = venv_path(distro)
    python = path / "bin" / "python"
    done = path / ".complete"
    if done.is_file():
        return python
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path.parent / f".{path.name}.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)  # another test process may be making it
        if done.is_file():
            return python
        venv.EnvBuilder(with_pip=True, clear=True).create(path)
        env = {k: v for k, v in os.environ.items() if k not in ("_ROS_WHEELS_BOOTSTRAP_COMPLETE", "LD_LIBRARY_PATH")}
        env["PIP_DISABLE_PIP_VERSION_CHECK"] = "1"
        pip = subprocess.run(
            [str(python), "-m", "pip", "install", "-q", *PACKAGES[distro]],
            env=env,
            capture_output=True,
            text=True,
            check=False,
        )
        if pip.returncode != 0:
            text = pip.stdout + pip.stderr
            tail = " | ".join(text.strip().splitlines()[-3:])
            if any(marker in text for marker in _UNREACHABLE):
                raise RegistryUnreachable(f"pip cannot reach the package registry: {tail}")
            raise RuntimeError(f"pip install {' '.join(PACKAGES[distro])} failed: {tail}")
        done.write_text("\n".join(PACKAGES[distro]) + "\n")
    return python


def main(argv: list[str]) -> int:
    """Make the venvs (all by default) and build the generated types for Jazzy."""
    for distro in argv or list(PACKAGES):
        python = ros_venv(distro)
        print(f"{distro}: {python}", flush=True)
        if distro == "jazzy":
            env = dict(os.environ, RACECAR_SIM_ROS2_PYTHON=str(python))
            subprocess.run([sys.executable, "-m", "racecar_sim", "ros2-env", "--build"], env=env, check=True)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
