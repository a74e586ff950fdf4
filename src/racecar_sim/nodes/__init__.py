"""The node contract (contract.py) and what a car's nodes hold on the bus and the scheduler (scope.py)."""

from racecar_sim.nodes.contract import Cancellable, Node, NodeBase, NodeContext, Restartable, StaticTf, Timers

__all__ = ["Cancellable", "Node", "NodeBase", "NodeContext", "Restartable", "StaticTf", "Timers"]
