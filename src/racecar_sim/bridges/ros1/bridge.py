"""RosBridge: the sim's bus on a ROS 1 master, through ros_side.py (a rospy node under the ROS interpreter).

Outbound, every bus topic is advertised as its ROS 1 type when its first message comes, and each message is
serialized to ROS 1 bytes here (wire.py) and published as it is by the ROS side; a topic no ROS node subscribes
to is not serialized (latched ones always are), and sensors nobody reads skip their work (Bus.tap wants).
Inbound, the ROS side subscribes to every topic a sim node takes commands on and forwards the bytes; they wait
in a thread-safe inbox until the sim drains it, DRAIN_RATE times per sim second (and in spin_once()), when they
are deserialized and published on the bus; ROS service calls are answered there too, through bus.call.
"""

from __future__ import annotations

import logging
import pickle
import queue
import subprocess
import sys
import threading
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from racecar_sim.bridges.ros1 import catalog, nodes, wire
from racecar_sim.bridges.ros1.environment import ROS_SIDE
from racecar_sim.bridges.ros1.link import DATA, ID, RosSideLink
from racecar_sim.core.errors import ConfigError

if TYPE_CHECKING:
    from racecar_sim.runtime import Simulator

log = logging.getLogger("racecar_sim.ros1")
DRAIN_RATE = 200.0  # Hz of sim time: a command from ROS reaches the bus at most 5 ms of sim time late
SYNC_EVERY = 10  # drains between checks for new services and listened topics (20 Hz of sim time)
READY_TIMEOUT = 60.0  # s for the ROS side to register with the master
NODE_NAME = "racecar_sim"
QUEUE_SIZE = 10  # rospy publisher queue per subscriber connection: a slower node drops the oldest


@dataclass
class _Outbound:
    id: int
    cls: type
    latched: bool
    connections: int = 0
    seq: int = 0
    ok: bool = True


@dataclass
class _Inbound:
    topic: str
    cls: type


class RosBridge:
    """The sim on a ROS 1 master: topics, command subscriptions, services, /clock, /use_sim_time, and real ROS
    nodes started beside it.

    master_uri: None takes $ROS_MASTER_URI, and without it starts a roscore on 127.0.0.1 (port 11311 when free).
    RosUnavailable (one line: what to install) when there is no interpreter with rospy.
    """

    def __init__(self, sim: Simulator, master_uri: str | None = None, node_name: str = NODE_NAME) -> None:
        self.sim = sim
        self.node_name = node_name
        self._ros = nodes.RosNodes(master_uri)
        self.python, self.master_uri, self.env = self._ros.python, self._ros.master_uri, self._ros.env
        self.nodes = self._ros.processes
        self._inbox: queue.SimpleQueue[tuple[Any, ...]] = queue.SimpleQueue()
        self._out: dict[str, _Outbound] = {}
        self._by_id: dict[int, _Outbound] = {}
        self._in: dict[int, _Inbound] = {}
        self._subscribed: set[str] = set()
        self._services: dict[str, str] = {}
        self._injected: Any = None
        self._ready = threading.Event()
        self._drains = 0
        self._link: RosSideLink | None = None
        self._remove_tap: Any = None
        self._task: Any = None
        self.sent = 0  # messages published to ROS
        self.received = 0  # messages from ROS published on the bus

    # --- life cycle ----------------------------------------------------------------------------------------------
    def start(self) -> None:
        """Start the ROS side, set /use_sim_time, and wire every topic, command subscription and service."""
        self._ros.set_params({"/use_sim_time": True})
        command = [self.python, str(ROS_SIDE), "--name", self.node_name]
        self._link = RosSideLink(command, self.env, self._on_frame)
        deadline = time.monotonic() + READY_TIMEOUT
        while not self._ready.wait(0.1):
            if self._link.closed.is_set() or time.monotonic() > deadline:
                code = self._link.process.poll()
                self.close()
                raise ConfigError(
                    f"--ros: the ROS side ({ROS_SIDE.name} under {self.python}) did not start"
                    f"{f' (exit code {code})' if code is not None else ''}; see its messages above"
                )
        self._remove_tap = self.sim.bus.tap(self._on_bus, wants=self._wants)
        for topic, msg in self.sim.bus.latched_messages().items():
            self._on_bus(topic, msg)
        self._sync()
        self._task = self.sim.scheduler.every(DRAIN_RATE, self._on_tick, "ros1_bridge")

    def set_params(self, params: Mapping[str, Any]) -> None:
        """Put parameters (absolute names -> values) on the ROS parameter server."""
        self._ros.set_params(params)

    def get_param(self, name: str) -> Any:
        """A parameter from the ROS parameter server; KeyError if unset."""
        return self._ros.get_param(name)

    def start_node(
        self,
        package: str,
        node_type: str,
        name: str,
        namespace: str = "/",
        args: Sequence[str] = (),
        remaps: Sequence[tuple[str, str]] = (),
        env: Mapping[str, str] | None = None,
    ) -> subprocess.Popen[bytes]:
        """Start a real ROS node as rosrun would (Python nodes under the ROS interpreter), with the generated
        messages on its PYTHONPATH and this bridge's master; close() stops it."""
        return self._ros.start_node(package, node_type, name, namespace, args, remaps, env)

    def close(self) -> None:
        """Stop the started nodes, the ROS side, and the roscore this bridge started."""
        if self._task is not None:
            self._task.cancel()
            self._task = None
        if self._remove_tap is not None:
            self._remove_tap()
            self._remove_tap = None
        self._ros.stop_nodes()
        if self._link is not None:
            self._link.close()
            self._link = None
        self._ros.master.close()

    @property
    def _side(self) -> RosSideLink:
        """The link to the ROS side, between start() and close()."""
        if self._link is None:
            raise RuntimeError("the ROS bridge is not started")
        return self._link

    def __enter__(self) -> RosBridge:
        self.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # --- sim -> ROS ----------------------------------------------------------------------------------------------
    def _wants(self, topic: str) -> bool:
        out = self._out.get(topic)
        return out is None or (out.ok and (out.latched or out.connections > 0))

    def _on_bus(self, topic: str, msg: Any) -> None:
        if msg is self._injected:
            return  # it came from ROS: no echo
        out = self._out.get(topic) or self._advertise(topic, type(msg))
        if not out.ok or not (out.latched or out.connections > 0):
            return
        out.seq += 1
        try:
            data = wire.serialize(msg, out.seq)
        except (TypeError, ValueError, AttributeError, KeyError) as exc:
            out.ok = False
            log.warning("not bridging %s to ROS: %s", topic, exc)
            return
        self._side.send(DATA, ID.pack(out.id), data)
        self.sent += 1

    def _advertise(self, topic: str, cls: type) -> _Outbound:
        out = _Outbound(len(self._by_id) + 1, cls, self.sim.bus.is_latched(topic))
        self._out[topic] = self._by_id[out.id] = out
        try:
            ros_type = wire.ros1_name(wire.type_of(cls))
            wire.encoder(cls)
        except (TypeError, KeyError, ValueError) as exc:
            out.ok = False
            log.warning("not bridging %s to ROS: %s", topic, exc)
            return out
        self._side.send_control(
            op="advertise", id=out.id, topic=topic, type=ros_type, latch=out.latched, queue_size=QUEUE_SIZE
        )
        return out

    # --- ROS -> sim ----------------------------------------------------------------------------------------------
    def _on_frame(self, kind: int, payload: bytes) -> None:
        """Reader thread: keep what the sim must handle for its own thread; note connection counts at once."""
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
            self._ready.set()
        elif op["op"] == "call":
            self._inbox.put(("call", op))
        elif op["op"] == "error":
            if op.get("kind") == "advertise" and op.get("id") in self._by_id:
                self._by_id[op["id"]].ok = False
            print(f"racecar-sim: warning: ROS bridge: {op['text']}", file=sys.stderr)

    def _on_tick(self, now_ns: int) -> None:
        self._drains += 1
        if self._drains % SYNC_EVERY == 0:
            self._sync()
        self.spin_once()

    def spin_once(self, timeout: float = 0.0) -> int:
        """Publish on the bus what came from ROS and answer ROS service calls; waits up to `timeout` s for the
        first item (a paused sim's loop calls it so that /gazebo/unpause_physics is answered). Returns the count."""
        handled = 0
        try:
            item = self._inbox.get(timeout=timeout) if timeout > 0 else self._inbox.get_nowait()
            while True:
                self._handle(item)
                handled += 1
                item = self._inbox.get_nowait()
        except queue.Empty:
            return handled

    def _handle(self, item: tuple[Any, ...]) -> None:
        if item[0] == "msg":
            inbound = self._in.get(item[1])
            if inbound is None:
                return
            try:
                msg = wire.deserialize(item[2], inbound.cls)
            except ValueError as exc:
                log.warning("dropped a message on %s from ROS: %s", inbound.topic, exc)
                return
            self._injected = msg
            try:
                self.sim.bus.publish(inbound.topic, msg)
            except TypeError as exc:
                log.warning("dropped a message on %s from ROS: %s", inbound.topic, exc)
            finally:
                self._injected = None
            self.received += 1
        else:
            self._answer(item[1])

    def _answer(self, op: dict[str, Any]) -> None:
        name = op["service"]
        try:
            request_cls, _ = wire.service_classes(self._services[name])
            response = self.sim.bus.call(name, wire.deserialize(op["data"], request_cls))
            self._side.send_control(op="reply", call=op["call"], data=wire.serialize(response))
        except Exception as exc:
            self._side.send_control(op="reply", call=op["call"], error=f"{type(exc).__name__}: {exc}")

    # --- what to subscribe to and offer -------------------------------------------------------------------------
    def _sync(self) -> None:
        """Subscribe on ROS to topics the sim's nodes newly take commands on; follow services offered and gone."""
        for topic, declared in self.sim.bus.listened().items():
            if topic in self._subscribed:
                continue
            cls = declared
            if cls is None:  # the sim's own data (/scan for a driver), not a command taken from outside
                continue
            self._subscribed.add(topic)
            sub_id = len(self._in) + 1
            self._in[sub_id] = _Inbound(topic, cls)
            self._side.send_control(op="subscribe", id=sub_id, topic=topic, type=wire.ros1_name(wire.type_of(cls)))
        offered = {name: catalog.service_type(name) for name in self.sim.bus.services()}
        for name in set(self._services) - set(offered):
            del self._services[name]
            self._side.send_control(op="unservice", name=name)
        for name, srv_type in offered.items():
            if srv_type is not None and name not in self._services:
                self._services[name] = srv_type
                self._side.send_control(op="service", name=name, type=wire.ros1_name(srv_type))
