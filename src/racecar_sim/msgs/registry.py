"""Lookup between ROS 2 type names and the message classes of this package."""

from __future__ import annotations

from typing import Any

from racecar_sim.msgs.generate import message_type


def message_class(msgtype: str) -> type[Any]:
    """The class for ``msgtype`` (``pkg/msg/Name`` or ``pkg/Name``): the one made from its definition.

    Raises:
        KeyError: This package has no definition of that type.
        ValueError: The name is not a message type name.
    """
    try:
        return message_type(msgtype)
    except KeyError:
        raise KeyError(f"no message class for {msgtype!r}") from None


def msgtype_of(msg_or_cls: object) -> str:
    """The ROS 2 type name (``pkg/msg/Name``) of a message instance or class.

    Raises:
        TypeError: The object is not a message.
    """
    msgtype = getattr(msg_or_cls, "__msgtype__", None)
    if not isinstance(msgtype, str):
        raise TypeError(f"not a ROS message (no __msgtype__): {type(msg_or_cls).__name__}")
    return msgtype
