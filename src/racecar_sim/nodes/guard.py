"""A user's node behind a guard: whatever its code raises stops the run with one NodeError naming the node, its car, the
sim time and what the sim was calling, chained from the node's own exception.

A user's node (a driver given as `file.py:Class`, or `sim.add_node(Class)`) is built from a copy of its car's context
whose bus and timers wrap each callback the node hands them (a subscription, a service, a timer); its hooks are called
through the guard too. The car's own nodes are not wrapped: their callbacks cost nothing extra.
"""

from __future__ import annotations

import dataclasses
import os
import sys
import traceback
from collections.abc import Callable, Mapping
from typing import TYPE_CHECKING, Any, TypeVar

from racecar_sim.bus import BusPort
from racecar_sim.core.errors import NodeError
from racecar_sim.core.time import NS_PER_S
from racecar_sim.nodes.contract import Cancellable, Node, NodeContext, Restartable, Timers

if TYPE_CHECKING:
    import mujoco

FILE_MODULE_PREFIX = "racecar_sim_driver_"  # the module name a node class loaded from `path/file.py` gets
_PACKAGE = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))  # racecar_sim/: frames of ours
T = TypeVar("T")


def node_label(factory: Callable[..., Any]) -> str:
    """How a node class is named to its user: `file.py:Class` for a class loaded from a file, `module:Class` else."""
    module_name = getattr(factory, "__module__", "") or ""
    name = getattr(factory, "__qualname__", None) or getattr(factory, "__name__", None) or repr(factory)
    module = sys.modules.get(module_name)
    path = getattr(module, "__file__", None)
    if module_name.startswith(FILE_MODULE_PREFIX) and path:
        return f"{os.path.basename(path)}:{name}"
    return f"{module_name}:{name}" if module_name else name


class NodeGuard:
    """Calls into one user's node: an exception is re-raised as NodeError (a NodeError from a node it called passes
    through unchanged)."""

    def __init__(self, label: str, car: str, now: Callable[[], int]) -> None:
        self.label, self.car, self.now = label, car, now

    def call(self, where: str, function: Callable[..., T], *args: Any, **kwargs: Any) -> T:
        """`function(*args, **kwargs)`, guarded; `where` says what the sim was calling (for the error)."""
        try:
            return function(*args, **kwargs)
        except NodeError:
            raise
        except Exception as exc:
            raise NodeError(self.label, self.car, self.now() / NS_PER_S, where, exc) from exc

    def wrap(self, where: str, function: Callable[..., T]) -> Callable[..., T]:
        """`function`, guarded."""

        def guarded(*args: Any) -> T:
            try:
                return function(*args)
            except NodeError:
                raise
            except Exception as exc:
                raise NodeError(self.label, self.car, self.now() / NS_PER_S, where, exc) from exc

        return guarded


class GuardedBus:
    """A bus whose subscriptions and services call the node through its guard; everything else is the bus's."""

    def __init__(self, bus: BusPort, guard: NodeGuard) -> None:
        self._bus, self._guard = bus, guard
        self.publish = bus.publish
        self.has_listeners = bus.has_listeners
        self.listeners_epoch = bus.listeners_epoch
        self.tally = bus.tally
        self.delivered = bus.delivered
        self.cdr_only = bus.cdr_only
        self.publish_cdr = bus.publish_cdr
        self.publish_cdr_rows = bus.publish_cdr_rows
        self.publish_fed_rows = bus.publish_fed_rows
        self.latch = bus.latch
        self.call = bus.call

    def subscribe(
        self,
        topic: str,
        callback: Callable[[Any], None],
        msgtype: type | None = None,
        feeds: Mapping[str, type] | None = None,
    ) -> Any:
        """The bus's subscribe(), the callback guarded."""
        return self._bus.subscribe(topic, self._guard.wrap(f"its subscription to {topic}", callback), msgtype, feeds)

    def advertise_service(self, name: str, handler: Callable[[Any], Any]) -> None:
        """The bus's advertise_service(), the handler guarded."""
        self._bus.advertise_service(name, self._guard.wrap(f"its service {name}", handler))

    def __getattr__(self, name: str) -> Any:
        return getattr(self._bus, name)


class GuardedTimers:
    """Timers whose callbacks call the node through its guard."""

    def __init__(self, timers: Timers, guard: NodeGuard) -> None:
        self._timers, self._guard = timers, guard
        self.step_ns = timers.step_ns

    def every(
        self,
        rate_hz: float,
        callback: Callable[[int], None],
        name: str,
        start_ns: int = 0,
        unheard: Callable[[int], bool] | None = None,
    ) -> Cancellable:
        """The timers' every(), the callback guarded."""
        where = f"its timer {name} ({rate_hz:g} Hz)"
        return self._timers.every(rate_hz, self._guard.wrap(where, callback), name, start_ns, unheard)

    def at(self, time_ns: int, callback: Callable[[int], None], name: str) -> Cancellable:
        """The timers' at(), the callback guarded."""
        return self._timers.at(time_ns, self._guard.wrap(f"its timer {name}", callback), name)

    def timeout(self, callback: Callable[[int], None], name: str) -> Restartable:
        """The timers' timeout(), the callback guarded."""
        return self._timers.timeout(self._guard.wrap(f"its timeout {name}", callback), name)

    def __getattr__(self, name: str) -> Any:
        return getattr(self._timers, name)


class GuardedNode:
    """A user's node as its car holds it: built from a guarded copy of the car's context, its hooks called through the
    guard. `node` is the user's object."""

    def __init__(self, factory: Callable[..., Node], ctx: NodeContext, car: str, **params: Any) -> None:
        self.guard = NodeGuard(node_label(factory), car, ctx.now)
        self.ctx = dataclasses.replace(
            ctx, bus=GuardedBus(ctx.bus, self.guard), timers=GuardedTimers(ctx.timers, self.guard)
        )
        self.node: Node = self.guard.call("its constructor", factory, self.ctx, **params)
        if not isinstance(factory, type):  # a function that builds it (`lambda ctx: JoyNode(...)`): named by its class
            self.guard.label = node_label(type(self.node))

    def reset(self, seed: int) -> None:
        """The node's reset hook (its context takes the new seed first, as the car's does)."""
        self.ctx.seed = seed
        self.guard.call("its reset hook", self.node.reset, seed)

    def rebind(self, model: mujoco.MjModel, data: mujoco.MjData) -> None:
        """The node's rebind hook, its context on the new model first."""
        self.ctx.model, self.ctx.data = model, data
        self.guard.call("its rebind hook", self.node.rebind, model, data)

    def close(self) -> None:
        """The node's close hook."""
        self.guard.call("its close hook", self.node.close)


def user_frames(error: BaseException) -> str:
    """The traceback of what a user's node raised (a NodeError's cause), its own frames only: none of racecar-sim's,
    which only called it."""
    cause = error.__cause__ if isinstance(error, NodeError) and error.__cause__ is not None else error
    frames = [f for f in traceback.extract_tb(cause.__traceback__) if not f.filename.startswith(_PACKAGE + os.sep)]
    text = "".join(traceback.format_list(frames)) + "".join(traceback.format_exception_only(type(cause), cause))
    return "Traceback (the node's own frames):\n" + text if frames else text
