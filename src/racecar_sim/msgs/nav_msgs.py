"""ROS 2 ``nav_msgs``: a class for each definition in msgs/definitions/nav_msgs (msgs/generate.py)."""

from __future__ import annotations

from typing import TYPE_CHECKING

from racecar_sim.msgs.generate import package_getattr

if TYPE_CHECKING:
    from racecar_sim.msgs.typed.nav_msgs import *  # noqa: F403  # the classes' types, from the same definitions

__getattr__ = package_getattr(__name__)
