"""The ROS 1 master: the one at ROS_MASTER_URI, or a roscore started on 127.0.0.1 and stopped at close().

Parameters go onto the parameter server over the master's XML-RPC API, from this interpreter (no rospy here).
"""

from __future__ import annotations

import os
import shutil
import signal
import socket
import subprocess
import time
import xmlrpc.client
from collections.abc import Mapping
from typing import Any

import numpy as np

from racecar_sim.bridges.ros1.environment import INSTALL, LOOPBACK, RosUnavailable
from racecar_sim.core.errors import ConfigError

DEFAULT_PORT = 11311
DEFAULT_URI = f"http://{LOOPBACK}:{DEFAULT_PORT}/"  # where `run --ros` starts its roscore when the port is free
START_TIMEOUT = 30.0  # s for a roscore to answer
CALLER_ID = "/racecar_sim"


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
            return s.getsockname()[1]
    raise OSError("no free port")


def master_up(uri: str) -> bool:
    """Whether a ROS master answers at `uri`."""
    try:
        code, _, _ = xmlrpc.client.ServerProxy(uri).getPid(CALLER_ID)
        return code == 1
    except (OSError, xmlrpc.client.Error):
        return False


class Master:
    """A connection to a ROS master; starts a roscore on 127.0.0.1 when `uri` is None."""

    def __init__(self, uri: str | None, env: Mapping[str, str] | None = None, port: int | None = DEFAULT_PORT) -> None:
        self._process: subprocess.Popen | None = None
        if uri is None:
            uri = self._start(free_port(port), dict(env or os.environ))
        elif not master_up(uri):
            raise ConfigError(f"--ros: no ROS master answers at {uri} (ROS_MASTER_URI / --ros-master): start "
                              "roscore there, or leave both unset to have racecar-sim start one")
        self.uri = uri
        self._proxy = xmlrpc.client.ServerProxy(uri, allow_none=True)

    def _start(self, port: int, env: dict[str, str]) -> str:
        uri = f"http://{LOOPBACK}:{port}/"
        env.setdefault("ROS_IP", LOOPBACK)
        env["ROS_MASTER_URI"] = uri
        try:  # its own session: close() stops roscore, rosmaster and rosout together
            roscore = shutil.which("roscore", path=env.get("PATH")) or "roscore"
            self._process = subprocess.Popen([roscore, "-p", str(port)], env=env, stdout=subprocess.DEVNULL,
                                             stderr=subprocess.DEVNULL, stdin=subprocess.DEVNULL,
                                             start_new_session=True)
        except FileNotFoundError:
            raise RosUnavailable(f"--ros: no roscore on PATH (and no ROS_MASTER_URI); install ROS 1: {INSTALL}") from None
        deadline = time.monotonic() + START_TIMEOUT
        while not master_up(uri):
            if self._process.poll() is not None or time.monotonic() > deadline:
                self.close()
                raise ConfigError(f"--ros: roscore -p {port} did not start (see ~/.ros/log); give a running master "
                                  "with ROS_MASTER_URI")
            time.sleep(0.1)
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
        code, message, value = self._proxy.getParam(CALLER_ID, name)
        if code != 1:
            raise KeyError(f"{name}: {message}")
        return value

    def close(self) -> None:
        """Stop the roscore if this object started it."""
        process, self._process = self._process, None
        if process is None or process.poll() is not None:
            return
        try:
            os.killpg(process.pid, signal.SIGINT)
            process.wait(10)
        except subprocess.TimeoutExpired:
            os.killpg(process.pid, signal.SIGKILL)
            process.wait()
        except ProcessLookupError:
            pass


def _plain(value: Any) -> Any:
    """XML-RPC has no numpy or tuples: plain lists, numbers and strings."""
    if isinstance(value, Mapping):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple, np.ndarray)):
        return [_plain(v) for v in value]
    if isinstance(value, np.generic):
        return value.item()
    return value
