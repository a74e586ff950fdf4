"""Starting a real ROS node as rosrun and roslaunch do: the executable found in its package, with its name,
namespace and remappings as `__name:=`, `ROS_NAMESPACE` and `from:=to` arguments."""

from __future__ import annotations

import os
import signal
import subprocess
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from racecar_sim.bridges.ros1.environment import (
    message_path,
    ros_environment,
    ros_python,
)
from racecar_sim.bridges.ros1.master import Master
from racecar_sim.core.errors import ConfigError
from racecar_sim.description.ros_packages import find_package

_SKIPPED = {".git", "build", "devel", "node_modules", "__pycache__"}
STOP_TIMEOUT = 5.0  # s a node has to exit after SIGINT before it is killed


class RosNodes:
    """Real ROS 1 nodes on a master, as roslaunch runs them: the parameters, the node processes, and the roscore
    when none runs. The bridge starts its nodes through one; `racecar-sim launch --ros` of a launch file with no
    car (the original teleop.launch, next to a running `racecar-sim run --ros`) uses one alone.

    master_uri: None takes $ROS_MASTER_URI, and without it starts a roscore on 127.0.0.1 (port 11311 when free).
    RosUnavailable (one line: what to install) when there is no interpreter with rospy.
    """

    def __init__(self, master_uri: str | None = None) -> None:
        self.python = ros_python()
        self.messages = message_path(self.python)
        self.master = Master(
            master_uri or os.environ.get("ROS_MASTER_URI") or None, ros_environment(None, self.messages)
        )
        self.master_uri = self.master.uri
        self.env = ros_environment(self.master_uri, self.messages)
        self.processes: list[subprocess.Popen[bytes]] = []

    def set_params(self, params: Mapping[str, Any]) -> None:
        """Put parameters (absolute names -> values) on the ROS parameter server."""
        self.master.set_params(params)

    def get_param(self, name: str) -> Any:
        """A parameter from the ROS parameter server; KeyError if unset."""
        return self.master.get_param(name)

    def start_node(
        self,
        package: str,
        node_type: str,
        name: str,
        namespace: str = "/",
        args: Sequence[str] = (),
        remaps: Sequence[tuple[str, str]] = (),
        env: Mapping[str, str] | None = None,
    ) -> subprocess.Popen[bytes]:
        """Start a real ROS node as rosrun would (Python nodes under the ROS interpreter), with the generated
        messages on its PYTHONPATH and this master; close() stops it."""
        executable = find_executable(package, node_type)
        command = node_command(executable, self.python, name, args, remaps)
        process = start(command, {**self.env, **(env or {})}, namespace)
        self.processes.append(process)
        return process

    def stop_nodes(self) -> None:
        """Stop the nodes started here, last first."""
        for process in reversed(self.processes):
            stop(process)
        self.processes.clear()

    def close(self) -> None:
        """Stop the nodes, then the roscore if it was started here."""
        self.stop_nodes()
        self.master.close()


def find_executable(package: str, node_type: str) -> Path:
    """`node_type` inside the package's folder (as rosrun looks: anywhere below it), or in a catkin libexec
    folder `lib/<package>` beside the share folder."""
    root = find_package(package)
    candidates = [root.parent.parent / "lib" / package / node_type]
    for folder, dirs, files in os.walk(root):
        dirs[:] = [d for d in dirs if d not in _SKIPPED]
        if node_type in files:
            candidates.append(Path(folder) / node_type)
    for path in candidates:
        if path.is_file() and (os.access(path, os.X_OK) or path.suffix == ".py"):
            return path
    raise ConfigError(
        f"node type '{node_type}' not found in package '{package}' ({root}): check <node type=...>, "
        "or make the file executable"
    )


def node_command(
    executable: Path, python: str, name: str, args: Sequence[str] = (), remaps: Sequence[tuple[str, str]] = ()
) -> list[str]:
    """The command line of a node: Python nodes run under the ROS interpreter (their shebang may name another)."""
    head = [python, str(executable)] if _is_python(executable) else [str(executable)]
    return [*head, *args, *[f"{a}:={b}" for a, b in remaps], f"__name:={name.rsplit('/', 1)[-1]}"]


def _is_python(path: Path) -> bool:
    if path.suffix == ".py":
        return True
    try:
        with open(path, "rb") as f:
            first = f.readline(200)
    except OSError:
        return False
    return first.startswith(b"#!") and b"python" in first


def start(command: Sequence[str], env: Mapping[str, str], namespace: str) -> subprocess.Popen[bytes]:
    """Start the node in its own session (so close() stops it and whatever it starts)."""
    env = dict(env)
    ns = "/" + namespace.strip("/") if namespace.strip("/") else "/"
    env["ROS_NAMESPACE"] = ns
    return subprocess.Popen(list(command), env=env, stdin=subprocess.DEVNULL, start_new_session=True)


def stop(process: subprocess.Popen[bytes], timeout: float = STOP_TIMEOUT) -> None:
    """SIGINT to the node's session (as roslaunch stops nodes), SIGKILL if it lingers."""
    if process.poll() is not None:
        return
    try:
        os.killpg(process.pid, signal.SIGINT)
        process.wait(timeout)
    except subprocess.TimeoutExpired:
        os.killpg(process.pid, signal.SIGKILL)
        process.wait()
