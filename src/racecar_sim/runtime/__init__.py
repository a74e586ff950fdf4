"""The runtime: sim clock, scheduler and the Simulator that wires every node onto the bus."""

from racecar_sim.core.scheduler import Scheduler, Task
from racecar_sim.runtime.simulator import Simulator

__all__ = ["Scheduler", "Simulator", "Task"]
