"""The runtime: the Simulator (a scene, an event loop, cars with their nodes, the world's nodes), the scheduler, the
registry of the description's sensor and plugin blocks (plugins.py) and Gazebo's ROS API."""

from racecar_sim.runtime.car import Car
from racecar_sim.runtime.scheduler import Scheduler, Task
from racecar_sim.runtime.simulator import Collision, Simulator

__all__ = ["Car", "Collision", "Scheduler", "Simulator", "Task"]
