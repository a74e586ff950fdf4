# Written by `python -m racecar_sim.msgs.stubs` from msgs/definitions: do not edit.
from typing import ClassVar

from racecar_sim.msgs._base import Message

class EmptyRequest(Message):
    """std_srvs/Empty request (no fields)."""

    __msgtype__: ClassVar[str]
    __srvtype__: ClassVar[str]
    def __init__(self) -> None: ...

class EmptyResponse(Message):
    """std_srvs/Empty response (no fields)."""

    __msgtype__: ClassVar[str]
    __srvtype__: ClassVar[str]
    def __init__(self) -> None: ...

class Empty:
    """The service std_srvs/srv/Empty, rclpy-style: ``Empty.Request()``, ``Empty.Response()``."""

    __srvtype__: ClassVar[str]
    Request = EmptyRequest
    Response = EmptyResponse
