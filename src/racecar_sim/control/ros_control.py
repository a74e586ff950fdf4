"""gazebo_ros_control: what `<plugin filename="libgazebo_ros_control.so">` starts for a car.

The plugin loads the robot's transmissions and runs the controller_manager; racecar_control.launch's spawner then
loads the controllers of racecar_control.yaml. Here the controllers' 1 kHz loop is MuJoCo actuators (added to the
MjSpec by `prepare`, control/controllers.py), and the node holds what lives on the bus: the controllers' command
topics (ControllerCommands), joint_state_controller, and the controller_manager with its services and state topics.
"""

from __future__ import annotations

import mujoco

from racecar_sim.control.commands import ControllerCommands
from racecar_sim.control.controller_manager import ControllerManager
from racecar_sim.control.controllers import add_actuators
from racecar_sim.control.joint_state_controller import JointStatePublisher
from racecar_sim.description.urdf import Plugin
from racecar_sim.nodes import Mount, NodeBase, NodeContext

PLUGIN = "libgazebo_ros_control.so"


def prepare(spec: mujoco.MjSpec, plugin: Plugin | None, mount: Mount) -> None:
    """Before compiling: an actuator per controller of the car's racecar_control.yaml (the controller loop)."""
    if mount.controllers is not None:
        add_actuators(spec, mount.controllers, mount.robot, mount.names)


class RosControl(NodeBase):
    """The controllers' command topics, joint_state_controller and the controller_manager of one car."""

    def __init__(self, ctx: NodeContext, plugin: Plugin | None = None) -> None:
        config, robot, state = (
            ctx.controllers,
            ctx.need_robot("gazebo_ros_control"),
            ctx.need_state("gazebo_ros_control"),
        )
        if config is None:
            raise TypeError("gazebo_ros_control needs the car's controller configuration (racecar_control.yaml)")
        self.commands = ControllerCommands(ctx.bus, state, config, robot, ctx.now, ctx.names)
        joints = [c.joint for c in config.controllers]
        topic = ctx.names.topic(f"{config.namespace}/joint_states")
        self.joint_states = JointStatePublisher(ctx.bus, ctx.timers, state, joints, config.joint_state_rate, topic)
        self.manager = ControllerManager(ctx.bus, ctx.timers, state, config, robot, self.joint_states, ctx.names)

    def reset(self, seed: int) -> None:
        """Every controller of the YAML loaded and running again, as the spawner leaves them."""
        self.manager.reset()
        self.manager.state_publisher.reset()
        self.joint_states.reset()
