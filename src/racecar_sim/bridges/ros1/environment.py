"""Where ROS 1 is: the interpreter that has rospy, the generated message packages, the environment of ROS processes.

Debian's rospy is built for the system interpreter (/usr/bin/python3); the sim may run under another. The ROS
interpreter is $RACECAR_SIM_ROS_PYTHON, else the first of this interpreter and /usr/bin/python3 that imports rospy.
The message packages Debian does not ship (ackermann_msgs, gazebo_msgs, control_msgs, controller_manager_msgs)
are generated with genpy from the definitions in definitions/ into $XDG_CACHE_HOME/racecar_sim/ros1_msgs/<hash>/,
once per version of the definitions, and put on the PYTHONPATH of every ROS process the bridge starts.
"""

from __future__ import annotations

import hashlib
import os
import shutil
import subprocess
import sys
import tempfile
from functools import cache
from pathlib import Path

from racecar_sim.core.errors import ConfigError

PYTHON_VARIABLE = "RACECAR_SIM_ROS_PYTHON"
SYSTEM_PYTHON = "/usr/bin/python3"
INSTALL = (
    "sudo apt-get install ros-core python3-rospy python3-rosgraph python3-genpy python3-sensor-msgs "
    "python3-nav-msgs python3-geometry-msgs python3-tf2-msgs python3-rosbag"
)
ROS_SIDE = Path(__file__).with_name("ros_side.py")
DEFINITIONS = Path(__file__).with_name("definitions")
LOOPBACK = "127.0.0.1"


class RosUnavailable(ConfigError):
    """ROS 1 (rospy, roscore) is not installed where the bridge looks for it."""


def _imports_rospy(python: str) -> bool:
    try:
        return (
            subprocess.run(
                [python, "-c", "import rospy, genpy, rosgraph"],
                stdout=subprocess.DEVNULL,
                stderr=subprocess.DEVNULL,
                timeout=30,
            ).returncode
            == 0
        )
    except (OSError, subprocess.TimeoutExpired):
        return False


@cache
def _find_python(given: str | None) -> str:
    if given:
        if not _imports_rospy(given):
            raise RosUnavailable(f"--ros: {PYTHON_VARIABLE}={given} cannot import rospy; install ROS 1: {INSTALL}")
        return given
    for python in dict.fromkeys((sys.executable, SYSTEM_PYTHON)):
        if Path(python).exists() and _imports_rospy(python):
            return python
    raise RosUnavailable(f"--ros needs ROS 1 (rospy for {SYSTEM_PYTHON}, roscore); install it: {INSTALL}")


def ros_python() -> str:
    """The interpreter that imports rospy; RosUnavailable (one line: what to install) if there is none."""
    return _find_python(os.environ.get(PYTHON_VARIABLE) or None)


def ros_available() -> bool:
    """Whether the bridge can run here: an interpreter with rospy, and roscore."""
    try:
        ros_python()
    except RosUnavailable:
        return False
    return shutil.which("roscore") is not None


def _cache_root() -> Path:
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "racecar_sim" / "ros1_msgs"


def _definitions_hash(python: str) -> str:
    digest = hashlib.sha256(python.encode())
    for path in sorted(DEFINITIONS.rglob("*.*")):
        digest.update(str(path.relative_to(DEFINITIONS)).encode() + b"\0" + path.read_bytes())
    digest.update(ROS_SIDE.read_bytes())  # the generator lives there
    return digest.hexdigest()[:16]


def message_path(python: str | None = None) -> Path:
    """The folder of generated message packages (to put on PYTHONPATH), generated first if needed.

    Only packages the ROS interpreter cannot import already are generated: a system gazebo_msgs is used as it is.
    """
    python = python or ros_python()
    target = _cache_root() / _definitions_hash(python)
    if target.is_dir():
        return target
    target.parent.mkdir(parents=True, exist_ok=True)
    scratch = Path(tempfile.mkdtemp(prefix=".gen-", dir=target.parent))
    done = subprocess.run(
        [python, str(ROS_SIDE), "--generate", str(DEFINITIONS), str(scratch)], capture_output=True, text=True
    )
    if done.returncode != 0:
        shutil.rmtree(scratch, ignore_errors=True)
        detail = " ".join((done.stderr or done.stdout).split())[-300:]
        raise ConfigError(f"--ros: generating the ROS 1 message packages from {DEFINITIONS} failed: {detail}")
    try:
        scratch.rename(target)
    except OSError:  # another process generated it meanwhile
        shutil.rmtree(scratch, ignore_errors=True)
    return target


def ros_environment(
    master_uri: str | None, messages: Path | None, extra: dict[str, str] | None = None
) -> dict[str, str]:
    """The environment of a ROS process the bridge starts: the master, loopback unless ROS_IP/ROS_HOSTNAME say
    otherwise, the generated messages on PYTHONPATH, a PATH without this virtual environment's scripts (PyPI's
    rospkg installs a `rosversion` there that roscore would run instead of Debian's), and `extra` on top."""
    env = dict(os.environ)
    if master_uri:
        env["ROS_MASTER_URI"] = master_uri
    if sys.prefix != sys.base_prefix:
        venv_bin = os.path.join(sys.prefix, "bin")
        env["PATH"] = os.pathsep.join(
            p for p in env.get("PATH", "").split(os.pathsep) if p and os.path.realpath(p) != os.path.realpath(venv_bin)
        )
        env.pop("VIRTUAL_ENV", None)
    if not env.get("ROS_IP") and not env.get("ROS_HOSTNAME"):
        env["ROS_IP"] = LOOPBACK
    if messages is not None:
        env["PYTHONPATH"] = os.pathsep.join(p for p in (str(messages), env.get("PYTHONPATH", "")) if p)
    env.update(extra or {})
    return env
