"""``gazebo_msgs`` (ROS 1 noetic definitions, as gazebo_ros_api_plugin offers them): the state topics and services.

LinkStates and ModelStates are published on ``/gazebo/link_states`` and ``/gazebo/model_states`` and recorded
like every topic; ModelState is also the message of the ``/gazebo/set_model_state`` topic. Each class is made from
its definition in msgs/definitions/gazebo_msgs (msgs/generate.py): a message from its ``.msg``, a service's request
and response from its ``.srv``, field for field: ``GetModelStateRequest`` (rospy) is also ``GetModelState.Request``
(rclpy). Services travel only over the in-process bus (``bus.call``) and the bridges, never to a recording.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from racecar_sim.msgs.generate import package_getattr

if TYPE_CHECKING:
    from racecar_sim.msgs.typed.gazebo_msgs import *  # noqa: F403  # the classes' types, from the same definitions

__getattr__ = package_getattr(__name__)
