"""``controller_manager_msgs`` (ROS 1 noetic): ControllerState and the controller manager's services.

ControllerState and HardwareInterfaceResources are messages (``.msg``, with CDR); the services' requests and responses
(ListControllers, ListControllerTypes, LoadController, UnloadController, SwitchController) are made from their
``.srv`` files in msgs/definitions/controller_manager_msgs (msgs/generate.py): they travel only through ``Bus.call``
and the bridges.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from racecar_sim.msgs.generate import package_getattr

if TYPE_CHECKING:
    from racecar_sim.msgs.typed.controller_manager_msgs import *  # noqa: F403  # the classes' types

__getattr__ = package_getattr(__name__)
