"""The node contract (contract.py) and what a car's nodes hold on the bus and the scheduler (scope.py)."""

from racecar_sim.nodes.contract import Cancellable, Mount, Node, NodeBase, NodeContext, Restartable, StaticTf, Timers
from racecar_sim.nodes.parts import Parts
from racecar_sim.nodes.scope import ScopedBus, ScopedTimers

__all__ = [
    "Cancellable",
    "Mount",
    "Node",
    "NodeBase",
    "NodeContext",
    "Parts",
    "Restartable",
    "ScopedBus",
    "ScopedTimers",
    "StaticTf",
    "Timers",
]
