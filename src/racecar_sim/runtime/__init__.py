"""The runtime: sim clock, scheduler, cars and the Simulator that wires every node onto the bus."""

from racecar_sim.runtime.car import Car
from racecar_sim.runtime.scheduler import Scheduler, Task
from racecar_sim.runtime.simulator import Collision, Simulator

__all__ = ["Car", "Collision", "Scheduler", "Simulator", "Task"]
