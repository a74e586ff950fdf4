"""``std_srvs``: Empty, the request and response of /gazebo/pause_physics, unpause_physics, reset_simulation and
reset_world. Services travel only over the in-process bus (``bus.call``), never to a recording."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

from racecar_sim.msgs._base import Message


@dataclass(eq=False, repr=False, slots=True)
class EmptyRequest(Message):
    """std_srvs/Empty request (no fields)."""

    __msgtype__: ClassVar[str] = "std_srvs/srv/Empty_Request"


@dataclass(eq=False, repr=False, slots=True)
class EmptyResponse(Message):
    """std_srvs/Empty response (no fields)."""

    __msgtype__: ClassVar[str] = "std_srvs/srv/Empty_Response"


class Empty:
    """The service type, rclpy-style: ``Empty.Request()``, ``Empty.Response()``."""

    Request = EmptyRequest
    Response = EmptyResponse
