"""What the ROS bridges share: a tap on the bus going out, a thread-safe inbox coming in, drained at sim events.

A bridge's reader thread never touches the bus: what comes from the other side (messages, service calls) waits in
the inbox until the sim drains it, DRAIN_RATE times per sim second (and in spin_once(), which a run loop calls after
each slice and a paused sim's loop while it waits), on the sim's own thread. A drain with an empty inbox does not stop
the physics (the scheduler's `unheard`): it only sends what waits for the other side. A message from the other side
is published on the bus as any in-process message, so the sim's own checks (types, NaN, ranges) apply; it is not
sent back on the topic it came in on (no echo), but what it becomes on other topics (a mux's output) goes out like
everything else.
"""

from __future__ import annotations

import logging
import pickle
import queue
import sys
import threading
import time
from typing import TYPE_CHECKING, Any, TypeVar

from racecar_sim.bridges.link import DATA, ID

if TYPE_CHECKING:
    from racecar_sim.runtime import Simulator

B = TypeVar("B", bound="BusBridge")
DRAIN_RATE = 200.0  # Hz of sim time: a command from outside reaches the bus at most 5 ms of sim time late
SYNC_EVERY = 10  # drains between checks for new services and listened topics (20 Hz of sim time)
SYNC_WALL = 0.02  # s of wall time at least between two such checks (a sim running ahead checks no more often)


class BusBridge:
    """The sim's side of a bridge. Subclasses send (`_send`), handle what the inbox holds (`_handle`), say which
    topics anyone reads on their side (`_wants`) and follow what the sim listens to and offers (`_sync`)."""

    task_name = "bridge"
    side_name = "ROS"  # in warnings: "ROS bridge: ..."
    log = logging.getLogger("racecar_sim.bridge")

    def __init__(self, sim: Simulator) -> None:
        self.sim = sim
        self._inbox: queue.SimpleQueue[tuple[Any, ...]] = queue.SimpleQueue()
        self._injected: tuple[str, Any] | None = None  # (topic, message) being published on the bus from outside
        self._drains = 0
        self._synced = 0.0  # perf_counter() at the last _sync
        self._remove_tap: Any = None
        self._task: Any = None
        self.sent = 0  # messages sent to the other side
        self.received = 0  # messages from the other side published on the bus
        self._by_id: dict[int, Any] = {}  # outbound topics by their id on the link: .connections, .ok
        self._ready = threading.Event()  # the other side said it is ready

    def start(self) -> None:
        """Start the other side and begin bridging."""
        raise NotImplementedError

    def close(self) -> None:
        """Stop bridging and the other side."""
        raise NotImplementedError

    def __enter__(self: B) -> B:
        self.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # --- to override ---------------------------------------------------------------------------------------------
    def _wants(self, topic: str) -> bool:
        """Whether the other side needs `topic`'s messages (Bus.tap's `wants`: a sensor nobody reads skips work)."""
        raise NotImplementedError

    def _send(self, topic: str, msg: Any) -> None:
        """A bus message to the other side."""
        raise NotImplementedError

    def _handle(self, item: tuple[Any, ...]) -> None:
        """One inbox item, on the sim's thread."""
        raise NotImplementedError

    def _sync(self) -> None:
        """Follow the topics the sim's nodes take commands on and the services offered."""
        raise NotImplementedError

    def _flush(self) -> None:
        """Send what waits for the other side (a batch); nothing by default."""

    def _on_ready(self, op: dict[str, Any]) -> None:
        """The other side's `ready` op (reader thread); nothing more by default."""

    def _on_failure(self, op: dict[str, Any]) -> bool:
        """An `error` op that stops the bridge (reader thread): True if it was one (kept for the sim's thread)."""
        return False

    # --- frames from the other side (bridges/link.py), on the reader thread ---------------------------------------
    def _on_frame(self, kind: int, payload: bytes) -> None:
        """Keep what the sim must handle for its own thread (messages, service calls); note connection counts and
        readiness at once; warn of the other side's errors (an advertise that failed stops that topic)."""
        if kind == DATA:
            (sub_id,) = ID.unpack_from(payload)
            self._inbox.put(("msg", sub_id, payload[ID.size :]))
            return
        op = pickle.loads(payload)
        if op["op"] == "connections":
            out = self._by_id.get(op["id"])
            if out is not None:
                out.connections = op["count"]
        elif op["op"] == "ready":
            self._on_ready(op)
            self._ready.set()
        elif op["op"] == "call":
            self._inbox.put(("call", op))
        elif op["op"] == "error" and not self._on_failure(op):
            if op.get("kind") == "advertise" and op.get("id") in self._by_id:
                self._by_id[op["id"]].ok = False
            print(f"racecar-sim: warning: {self.side_name} bridge: {op['text']}", file=sys.stderr)

    # --- the shared machinery ---------------------------------------------------------------------------------
    def _attach(self) -> None:
        """Tap the bus (latched topics first), subscribe and offer what the sim has, and drain at DRAIN_RATE."""
        self._remove_tap = self.sim.bus.tap(self._on_bus, wants=self._wants)
        for topic, msg in self.sim.bus.latched_messages().items():
            self._on_bus(topic, msg)
        self._sync()
        self._synced = time.perf_counter()
        self._task = self.sim.scheduler.every(DRAIN_RATE, self._on_tick, self.task_name, unheard=self._quiet_tick)

    def _detach(self) -> None:
        """Stop draining and untap the bus."""
        if self._task is not None:
            self._task.cancel()
            self._task = None
        if self._remove_tap is not None:
            self._remove_tap()
            self._remove_tap = None

    def _on_bus(self, topic: str, msg: Any) -> None:
        injected = self._injected
        if injected is not None and injected[1] is msg and injected[0] == topic:
            return  # it came from outside on this topic: no echo (the mux output it becomes goes out)
        self._send(topic, msg)

    def _inject(self, topic: str, msg: Any, source: str = "ROS") -> None:
        """Publish a message from the other side on the bus (on the sim's thread); a message of the wrong type is
        dropped with a warning."""
        self._injected = (topic, msg)
        try:
            self.sim.bus.publish(topic, msg)
        except TypeError as exc:
            self.log.warning("dropped a message on %s from %s: %s", topic, source, exc)
        finally:
            self._injected = None
        self.received += 1

    def _on_tick(self, now_ns: int) -> None:
        self._chores()
        if not self._inbox.empty():  # an empty inbox costs no exception (most drains of a run ahead of ROS)
            self._drain(0.0)

    def _quiet_tick(self, now_ns: int) -> bool:
        """A drain with nothing in the inbox needs no stop of the physics (Scheduler.every's `unheard`)."""
        if not self._inbox.empty():
            return False
        self._chores()
        return True

    def _chores(self) -> None:
        """At every drain: look for new command topics and services now and then, send what waits."""
        self._drains += 1
        if self._drains % SYNC_EVERY == 0 and time.perf_counter() - self._synced >= SYNC_WALL:
            self._sync()
            self._synced = time.perf_counter()
        self._flush()

    def spin_once(self, timeout: float = 0.0) -> int:
        """Send what waits for the other side, publish on the bus what came from it and answer its service calls;
        waits up to `timeout` s for the first item (a paused sim's loop calls it so that unpause_physics is
        answered). Returns the count."""
        self._flush()
        return self._drain(timeout)

    def _drain(self, timeout: float) -> int:
        handled = 0
        try:
            item = self._inbox.get(timeout=timeout) if timeout > 0 else self._inbox.get_nowait()
            while True:
                self._handle(item)
                handled += 1
                item = self._inbox.get_nowait()
        except queue.Empty:
            return handled
