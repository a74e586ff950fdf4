"""The bus and the timers as one car's nodes see them: everything they subscribe, offer and schedule is remembered, so
that the car can take it all away again when it is deleted (Gazebo's delete_model), whatever its nodes are."""

from __future__ import annotations

import weakref
from collections.abc import Callable, Mapping
from typing import Any

from racecar_sim.bus import BusPort
from racecar_sim.nodes.contract import Cancellable, Restartable, Timers


class ScopedBus:
    """The shared bus: everything passes through; subscriptions and services are remembered for release()."""

    def __init__(self, bus: BusPort) -> None:
        self._bus = bus
        self.publish = bus.publish  # the hot paths, as plain attributes: no wrapper call per message
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
        self._subscriptions: list[Any] = []
        self._services: list[str] = []

    def subscribe(
        self,
        topic: str,
        callback: Callable[[Any], None],
        msgtype: type | None = None,
        feeds: Mapping[str, type] | None = None,
    ) -> Any:
        """The bus's subscribe(), remembered."""
        sub = self._bus.subscribe(topic, callback, msgtype, feeds)
        self._subscriptions.append(sub)
        return sub

    def advertise_service(self, name: str, handler: Callable[[Any], Any]) -> None:
        """The bus's advertise_service(), remembered."""
        self._bus.advertise_service(name, handler)
        self._services.append(name)

    def release(self) -> None:
        """Drop every subscription and service made through this view."""
        for sub in self._subscriptions:
            sub.unsubscribe()
        unadvertise = getattr(self._bus, "unadvertise_service", None)
        for name in self._services:
            if unadvertise is not None:
                unadvertise(name)
        self._subscriptions, self._services = [], []

    def __getattr__(self, name: str) -> Any:
        return getattr(self._bus, name)


class ScopedTimers:
    """The shared scheduler: periodic tasks count from the car's start time (a car spawned at t = 2 s scans at
    2.025 s, ..., as a Gazebo sensor counts from its load), and every live task is remembered (weakly: fired one-shots
    are forgotten) so that cancel_all() can stop them."""

    def __init__(self, timers: Timers, start_ns: int) -> None:
        self._timers, self._start_ns = timers, start_ns
        self.step_ns = timers.step_ns
        self._tasks: weakref.WeakSet[Any] = weakref.WeakSet()

    def every(
        self,
        rate_hz: float,
        callback: Callable[[int], None],
        name: str,
        start_ns: int = 0,
        unheard: Callable[[int], bool] | None = None,
    ) -> Cancellable:
        """The scheduler's every(), from the car's start at the earliest, remembered."""
        task = self._timers.every(rate_hz, callback, name, max(start_ns, self._start_ns), unheard)
        self._tasks.add(task)
        return task

    def at(self, time_ns: int, callback: Callable[[int], None], name: str) -> Cancellable:
        """The scheduler's at(), remembered."""
        task = self._timers.at(time_ns, callback, name)
        self._tasks.add(task)
        return task

    def timeout(self, callback: Callable[[int], None], name: str) -> Restartable:
        """The scheduler's timeout(), remembered."""
        task = self._timers.timeout(callback, name)
        self._tasks.add(task)
        return task

    def cancel_all(self) -> None:
        """Stop every task scheduled through this view."""
        for task in list(self._tasks):
            task.cancel()

    def __getattr__(self, name: str) -> Any:
        return getattr(self._timers, name)
