"""``std_srvs``: Empty, the request and response of /gazebo/pause_physics, unpause_physics, reset_simulation and
reset_world, made from msgs/definitions/std_srvs/srv/Empty.srv (msgs/generate.py). Services travel only over the
in-process bus (``bus.call``) and the bridges, never to a recording."""

from __future__ import annotations

from typing import TYPE_CHECKING

from racecar_sim.msgs.generate import package_getattr

if TYPE_CHECKING:
    from racecar_sim.msgs.typed.std_srvs import *  # noqa: F403  # the classes' types, from the same definitions

__getattr__ = package_getattr(__name__)
