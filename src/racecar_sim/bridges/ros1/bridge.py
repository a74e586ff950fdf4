"""RosBridge: the sim's bus on a ROS 1 master, through ros_side.py (a rospy node under the ROS interpreter).

Outbound, every bus topic is advertised as its ROS 1 type when its first message comes, and each message is
serialized to ROS 1 bytes here (wire.py) and published as it is by the ROS side; a topic no ROS node subscribes
to is not serialized (latched ones always are), and sensors nobody reads skip their work (Bus.tap wants).
Inbound, the ROS side subscribes to every topic a sim node takes commands on and forwards the bytes; they wait
in a thread-safe inbox until the sim drains it, DRAIN_RATE times per sim second (and in spin_once()), when they
are deserialized and published on the bus; ROS service calls are answered there too, through bus.call. The inbox,
the drains and the no-echo rule are the shape every bridge shares (bridges/base.py).
"""

from __future__ import annotations

import logging
import subprocess
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from racecar_sim.bridges.base import DRAIN_RATE, BusBridge
from racecar_sim.bridges.ros1 import catalog, nodes, wire
from racecar_sim.bridges.ros1.batch import FrameBatch
from racecar_sim.bridges.ros1.environment import ROS_SIDE
from racecar_sim.bridges.ros1.link import RosSideLink
from racecar_sim.bridges.topic_map import IDENTITY, TopicMap
from racecar_sim.core.errors import ConfigError

if TYPE_CHECKING:
    from racecar_sim.runtime import Simulator

__all__ = ["DRAIN_RATE", "NODE_NAME", "RosBridge"]
log = logging.getLogger("racecar_sim.ros1")
READY_TIMEOUT = 60.0  # s for the ROS side to register with the master
NODE_NAME = "racecar_sim"
QUEUE_SIZE = 20  # rospy publisher queue per subscriber connection: a slower node drops the oldest
LATEST_ONLY = frozenset({"/clock"})  # in a batch, the newest replaces the one waiting (batch.py: nodes keep the newest)


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


class RosBridge(BusBridge):
    """The sim on a ROS 1 master: topics, command subscriptions, services, /clock, /use_sim_time, and real ROS
    nodes started beside it.

    master_uri: None takes $ROS_MASTER_URI, and without it starts a roscore on 127.0.0.1 (port 11311 when free).
    RosUnavailable (one line: what to install) when there is no interpreter with rospy.
    """

    task_name = "ros1_bridge"
    log = log

    def __init__(
        self,
        sim: Simulator,
        master_uri: str | None = None,
        node_name: str = NODE_NAME,
        topic_map: TopicMap = IDENTITY,
    ) -> None:
        super().__init__(sim)
        self.node_name = node_name
        self.topic_map = topic_map  # the names on ROS (bridges/topic_map.py); the bus keeps the sim's
        self._ros = nodes.RosNodes(master_uri)
        self.python, self.master_uri, self.env = self._ros.python, self._ros.master_uri, self._ros.env
        self.nodes = self._ros.processes
        self._out: dict[str, _Outbound] = {}
        self._by_id: dict[int, _Outbound] = {}
        self._in: dict[int, _Inbound] = {}
        self._subscribed: set[str] = set()
        self._services: dict[str, str] = {}
        # messages out, in batches; no more of one topic than half a rospy publisher queue
        self._batch = FrameBatch(lambda kind, *parts: self._side.send(kind, *parts), QUEUE_SIZE // 2)
        self._link: RosSideLink | None = None

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
        self._attach()

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
        self._detach()
        self._ros.stop_nodes()
        if self._link is not None:
            self._batch.flush()
            self._link.close()
            self._link = None
        self._ros.master.close()

    @property
    def _side(self) -> RosSideLink:
        """The link to the ROS side, between start() and close()."""
        if self._link is None:
            raise RuntimeError("the ROS bridge is not started")
        return self._link

    # --- sim -> ROS ----------------------------------------------------------------------------------------------
    def _wants(self, topic: str) -> bool:
        out = self._out.get(topic)
        return out is None or (out.ok and (out.latched or out.connections > 0))

    def _send(self, topic: str, msg: Any) -> None:
        out = self._out.get(topic) or self._advertise(topic, type(msg))
        if not out.ok or not (out.latched or out.connections > 0):
            return
        out.seq += 1
        try:
            data = wire.serialize(self.topic_map.to_ros(topic, msg), out.seq)
        except (TypeError, ValueError, AttributeError, KeyError) as exc:
            out.ok = False
            log.warning("not bridging %s to ROS: %s", topic, exc)
            return
        self._batch.add(out.id, data)
        self.sent += 1

    def _advertise(self, topic: str, cls: type) -> _Outbound:
        out = _Outbound(len(self._by_id) + 1, cls, self.sim.bus.is_latched(topic))
        self._out[topic] = self._by_id[out.id] = out
        ros_topic = self.topic_map.ros_name(topic)
        if ros_topic is None:  # not bridged under this topic map
            out.ok = False
            return out
        try:
            ros_type = wire.ros1_name(wire.type_of(cls))
            wire.encoder(cls)
        except (TypeError, KeyError, ValueError) as exc:
            out.ok = False
            log.warning("not bridging %s to ROS: %s", topic, exc)
            return out
        self._side.send_control(
            op="advertise", id=out.id, topic=ros_topic, type=ros_type, latch=out.latched, queue_size=QUEUE_SIZE
        )
        if topic in LATEST_ONLY:
            self._batch.latest_only.add(out.id)
        return out

    # --- ROS -> sim (frames: BusBridge._on_frame) -----------------------------------------------------------------
    def _flush(self) -> None:
        """At every drain: send the batch when due."""
        self._batch.flush_due()

    def spin_once(self, timeout: float = 0.0) -> int:
        """Send ROS what waits in the batch, publish on the bus what came from ROS and answer ROS service calls;
        waits up to `timeout` s for the first item (a paused sim's loop calls it so that /gazebo/unpause_physics is
        answered). A run loop calls it after each slice of sim time. Returns the count."""
        self._batch.flush()
        return super().spin_once(timeout)

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
            self._inject(inbound.topic, self.topic_map.from_ros(inbound.topic, msg))
        else:
            self._answer(item[1])

    def _answer(self, op: dict[str, Any]) -> None:
        name = op["service"]
        self._batch.flush()  # what was published before the answer reaches ROS before it
        try:
            request_cls, _ = wire.service_classes(self._services[name])
            response = self.sim.bus.call(name, wire.deserialize(op["data"], request_cls))
            self._side.send_control(op="reply", call=op["call"], data=wire.serialize(response))
        except Exception as exc:
            self._side.send_control(op="reply", call=op["call"], error=f"{type(exc).__name__}: {exc}")

    # --- what to subscribe to and offer -------------------------------------------------------------------------
    def _sync(self) -> None:
        """Subscribe on ROS to topics the sim's nodes newly take commands on; follow services offered and gone."""
        self._synced = time.perf_counter()
        for topic, declared in self.sim.bus.listened().items():
            if topic in self._subscribed:
                continue
            cls = declared
            if cls is None:  # the sim's own data (/scan for a driver), not a command taken from outside
                continue
            self._subscribed.add(topic)
            ros_topic = self.topic_map.ros_name(topic)
            if ros_topic is None:
                continue
            sub_id = len(self._in) + 1
            self._in[sub_id] = _Inbound(topic, cls)
            self._side.send_control(op="subscribe", id=sub_id, topic=ros_topic, type=wire.ros1_name(wire.type_of(cls)))
        offered = {name: catalog.service_type(name) for name in self.sim.bus.services()}
        for name in set(self._services) - set(offered):
            del self._services[name]
            self._side.send_control(op="unservice", name=name)
        for name, srv_type in offered.items():
            if srv_type is not None and name not in self._services:
                self._services[name] = srv_type
                self._side.send_control(op="service", name=name, type=wire.ros1_name(srv_type))
