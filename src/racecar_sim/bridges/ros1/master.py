"""The ROS 1 master: the one at ROS_MASTER_URI, or a roscore started on 127.0.0.1 and stopped at close().

The roscore started here is what `roscore` starts, every socket of it on 127.0.0.1: rosmaster (which binds to ROS_IP),
the parameters roscore.xml sets (/run_id, /rosversion, /rosdistro), and rosout - as the rospy node rosout.py, since
roscpp's rosout serves its XML-RPC API on every interface whatever ROS_IP says. ROS_IP is 127.0.0.1 unless the user
gave ROS_IP or ROS_HOSTNAME (then the user asked for the network: the processes bind as ROS binds them).
Parameters go onto the parameter server over the master's XML-RPC API, from this interpreter (no rospy here).
"""

from __future__ import annotations

import os
import shutil
import signal
import socket
import subprocess
import time
import uuid
import xmlrpc.client
from collections.abc import Mapping
from pathlib import Path
from typing import Any, cast

import numpy as np

from racecar_sim.bridges.ros1.environment import INSTALL, LOOPBACK, RosUnavailable, ros_python
from racecar_sim.core.errors import ConfigError

DEFAULT_PORT = 11311
DEFAULT_URI = f"http://{LOOPBACK}:{DEFAULT_PORT}/"  # where `run --ros` starts its roscore when the port is free
START_TIMEOUT = 30.0  # s for a roscore to answer
CALLER_ID = "/racecar_sim"
ROSOUT = Path(__file__).with_name("rosout.py")
_Reply = tuple[int, str, Any]  # what a ROS master API call returns: [code, statusMessage, value] (a list, unpacked)


def free_port(preferred: int | None = None) -> int:
    """`preferred` if nothing listens on it on 127.0.0.1, else a port the system picks."""
    for port in ((preferred,) if preferred else ()) + (0,):
        with socket.socket() as s:
            # as roscore binds: connections of a master that just stopped (TIME_WAIT) do not make the port busy
            s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
            try:
                s.bind((LOOPBACK, port))
            except OSError:
                continue
            return int(s.getsockname()[1])
    raise OSError("no free port")


def master_up(uri: str) -> bool:
    """Whether a ROS master answers at `uri`."""
    try:
        code, _, _ = cast(_Reply, xmlrpc.client.ServerProxy(uri).getPid(CALLER_ID))
        return code == 1
    except (OSError, xmlrpc.client.Error):
        return False


class Master:
    """A connection to a ROS master; starts a roscore on 127.0.0.1 when `uri` is None."""

    def __init__(self, uri: str | None, env: Mapping[str, str] | None = None, port: int | None = DEFAULT_PORT) -> None:
        self._process: subprocess.Popen[bytes] | None = None  # rosmaster
        self._rosout: subprocess.Popen[bytes] | None = None
        if uri is None:
            uri = self._start(free_port(port), dict(env or os.environ))
        elif not master_up(uri):
            raise ConfigError(
                f"--ros: no ROS master answers at {uri} (ROS_MASTER_URI / --ros-master): start "
                "roscore there, or leave both unset to have racecar-sim start one"
            )
        self.uri = uri
        self._proxy = xmlrpc.client.ServerProxy(uri, allow_none=True)

    def _start(self, port: int, env: dict[str, str]) -> str:
        uri = f"http://{LOOPBACK}:{port}/"
        if not env.get("ROS_IP") and not env.get("ROS_HOSTNAME"):
            env["ROS_IP"] = LOOPBACK
        env["ROS_MASTER_URI"] = uri
        path = env.get("PATH")
        if shutil.which("roscore", path=path) is None:
            raise RosUnavailable(f"--ros: no roscore on PATH (and no ROS_MASTER_URI); install ROS 1: {INSTALL}")
        rosmaster = shutil.which("rosmaster", path=path) or "rosmaster"
        python = ros_python()
        try:  # roscore's own command line for the master
            self._process = _start_quiet([rosmaster, "--core", "-p", str(port), "-w", "3"], env)
        except FileNotFoundError:
            raise RosUnavailable(
                f"--ros: no rosmaster on PATH (and no ROS_MASTER_URI); install ROS 1: {INSTALL}"
            ) from None
        deadline = time.monotonic() + START_TIMEOUT
        while not master_up(uri):
            if self._process.poll() is not None or time.monotonic() > deadline:
                self.close()
                raise ConfigError(
                    f"--ros: roscore -p {port} did not start (see ~/.ros/log); give a running master "
                    "with ROS_MASTER_URI"
                )
            time.sleep(0.1)
        proxy = xmlrpc.client.ServerProxy(uri)
        for name, value in (
            ("/run_id", str(uuid.uuid1())),
            ("/rosversion", _command(["rosversion", "roslaunch"], env)),
            ("/rosdistro", _command(["rosversion", "-d"], env)),
        ):
            if value is not None:  # as roscore.xml sets them (rosversion's output, newline and all)
                proxy.setParam(CALLER_ID, name, value)
        self._rosout = _start_quiet([python, str(ROSOUT), "__name:=rosout"], env)
        return uri

    @property
    def started(self) -> bool:
        """Whether this object started the roscore."""
        return self._process is not None

    def set_params(self, params: Mapping[str, Any]) -> None:
        """Put absolute parameter names and values on the parameter server."""
        for name, value in params.items():
            if not name.startswith("/"):
                raise ConfigError(f"parameter '{name}' must be absolute (start with '/')")
            self._proxy.setParam(CALLER_ID, name, _plain(value))

    def get_param(self, name: str) -> Any:
        """A parameter's value; KeyError if it is not set."""
        code, message, value = cast(_Reply, self._proxy.getParam(CALLER_ID, name))
        if code != 1:
            raise KeyError(f"{name}: {message}")
        return value

    def close(self) -> None:
        """Stop the roscore (rosout, then rosmaster) if this object started it."""
        processes, self._rosout, self._process = (self._rosout, self._process), None, None
        for process in processes:
            if process is None or process.poll() is not None:
                continue
            try:
                os.killpg(process.pid, signal.SIGINT)
                process.wait(10)
            except subprocess.TimeoutExpired:
                os.killpg(process.pid, signal.SIGKILL)
                process.wait()
            except ProcessLookupError:
                pass

    @property
    def pids(self) -> list[int]:
        """The processes of the roscore started here (rosmaster, rosout), running or not; none for a master given."""
        return [p.pid for p in (self._process, self._rosout) if p is not None]


def _start_quiet(command: list[str], env: dict[str, str]) -> subprocess.Popen[bytes]:
    """A roscore process with no input or output, in its own session: close() stops it and what it started."""
    return subprocess.Popen(
        command,
        env=env,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        stdin=subprocess.DEVNULL,
        start_new_session=True,
    )


def _command(command: list[str], env: Mapping[str, str]) -> str | None:
    """A command's output, as a launch file's `<param command>` takes it; None if it cannot run."""
    try:
        done = subprocess.run(command, env=dict(env), capture_output=True, text=True, timeout=30, check=False)
    except (OSError, subprocess.TimeoutExpired):
        return None
    return done.stdout if done.returncode == 0 else None


def _plain(value: Any) -> Any:
    """XML-RPC has no numpy or tuples: plain lists, numbers and strings."""
    if isinstance(value, Mapping):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple, np.ndarray)):
        return [_plain(v) for v in value]
    if isinstance(value, np.generic):
        return value.item()
    return value
