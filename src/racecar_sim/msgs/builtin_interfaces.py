"""ROS 2 ``builtin_interfaces``: a class per definition in msgs/definitions/builtin_interfaces (msgs/generate.py)."""

from __future__ import annotations

from typing import TYPE_CHECKING

from racecar_sim.msgs.generate import package_getattr

if TYPE_CHECKING:
    from racecar_sim.msgs.typed.builtin_interfaces import *  # noqa: F403  # the classes' types, from the same definitions

__getattr__ = package_getattr(__name__)
