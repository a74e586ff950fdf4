"""Ros2Bridge: the sim's bus on ROS 2, through ros_side.py (an rclpy node named racecar_sim, on Fast DDS).

Outbound, every bus topic is advertised with its ROS 2 type (sensor_msgs/msg/LaserScan, ...) and its QoS (qos.py)
when its first message comes, and each message is serialized here to the CDR the sim records (msgs.serialize) and
published as raw bytes by the ROS side; a topic no ROS 2 node subscribes to is not serialized (latched ones always
are), and sensors nobody reads skip their work (Bus.tap wants). Inbound, the ROS side subscribes (raw) to every topic
a sim node takes commands on; the bytes wait in the inbox until the sim drains it (bridges/base.py), when they are
deserialized (msgs.deserialize) and published on the bus, where the sim's own checks apply. The Gazebo ROS 2 services
and the controller managers' are answered there too (services.py). A topic map (bridges/topic_map.py) renames topics
and frames at this edge only.
"""

from __future__ import annotations

import sys
import time
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from racecar_sim.bridges.base import DRAIN_RATE, BusBridge
from racecar_sim.bridges.link import SideLink
from racecar_sim.bridges.ros2 import qos, services, types
from racecar_sim.bridges.ros2.environment import ROS_SIDE, RosPython, domain_id, ros2_environment, ros2_python
from racecar_sim.bridges.topic_map import IDENTITY, TopicMap
from racecar_sim.core.errors import ConfigError
from racecar_sim.msgs import deserialize, serialize
from racecar_sim.msgs.registry import msgtype_of

if TYPE_CHECKING:
    from racecar_sim.runtime import Simulator

__all__ = ["DRAIN_RATE", "NODE_NAME", "Ros2Bridge"]
NODE_NAME = "racecar_sim"
READY_TIMEOUT = 60.0  # s for the ROS side to start its node
FLUSH_WALL = 0.002  # s of wall time a message may wait in the batch for others to go with it


@dataclass
class _Outbound:
    id: int
    topic: str  # its name on ROS
    msgtype: str
    latched: bool
    depth: int = 10
    connections: int = 0
    ok: bool = True


@dataclass
class _Inbound:
    topic: str  # the bus topic
    ros_topic: str
    msgtype: str


class Ros2Bridge(BusBridge):
    """The sim on ROS 2: every topic with its ROS 2 type and QoS, the command topics subscribed, /clock for
    use_sim_time nodes, the Gazebo ROS 2 and controller manager services.

    `Ros2Bridge(sim).start()`; close() stops the ROS side. `ros`: the interpreter with rclpy (default: found as
    environment.ros2_python() finds it; Ros2Unavailable, one line naming what to install, when there is none).
    `topic_map`: the names on ROS (default: the sim's own). The generated types are built on first use.
    """

    side_name = "ROS 2"
    task_name = "ros2_bridge"

    def __init__(
        self,
        sim: Simulator,
        node_name: str = NODE_NAME,
        topic_map: TopicMap = IDENTITY,
        ros: RosPython | None = None,
    ) -> None:
        super().__init__(sim)
        self.node_name = node_name
        self.topic_map = topic_map
        self.ros = ros or ros2_python()
        self.types = types.build(self.ros, say=lambda line: print(line, file=sys.stderr))
        self.env = ros2_environment(self.ros, self.types)
        self.domain_id = domain_id(self.env)
        self._out: dict[str, _Outbound] = {}
        self._by_id: dict[int, _Outbound] = {}
        self._in: dict[int, _Inbound] = {}
        self._subscribed: set[str] = set()
        self._services: dict[str, services.Service] = {}
        self._warned: set[str] = set()
        self._failure: str | None = None
        self._link: SideLink | None = None
        self._flushed = 0.0  # perf_counter() at the last batch sent
        self.fully_qualified_name = "/" + node_name

    # --- life cycle ----------------------------------------------------------------------------------------------
    def start(self) -> None:
        """Start the ROS side, then wire every topic, command subscription and service."""
        command = [self.ros.python, str(ROS_SIDE), "--name", self.node_name]
        self._link = SideLink(command, self.env, self._on_frame, name="ros2-bridge-reader")
        deadline = time.monotonic() + READY_TIMEOUT
        while not self._ready.wait(0.1):
            if self._link.closed.is_set() or time.monotonic() > deadline:
                code = self._link.process.poll()
                self.close()
                if self._failure:
                    raise ConfigError(f"--ros2: {self._failure}")
                raise ConfigError(
                    f"--ros2: the ROS 2 side ({ROS_SIDE.name} under {self.ros.python}) did not start"
                    f"{f' (exit code {code})' if code is not None else ''}; see its messages above"
                )
        self._attach()

    def close(self) -> None:
        """Stop draining and stop the ROS side."""
        self._detach()
        if self._link is not None:
            self._link.close()
            self._link = None

    @property
    def _side(self) -> SideLink:
        if self._link is None:
            raise RuntimeError("the ROS 2 bridge is not started")
        return self._link

    # --- sim -> ROS ----------------------------------------------------------------------------------------------
    def _flush(self) -> None:
        """At a drain: send the batch when FLUSH_WALL has passed since the last one (a sim running ahead of the
        wall clock wakes the ROS side no more often than that)."""
        now = time.perf_counter()
        if self._link is not None and now - self._flushed >= FLUSH_WALL:
            self._link.flush()
            self._flushed = now

    def spin_once(self, timeout: float = 0.0) -> int:
        """As BusBridge.spin_once, everything waiting sent now; ConfigError (one line) once the ROS side found the
        domain taken."""
        self._raise_failure()
        if self._link is not None:
            self._link.flush()
            self._flushed = time.perf_counter()
        return super().spin_once(timeout)

    def _chores(self) -> None:
        self._raise_failure()
        super()._chores()

    def _raise_failure(self) -> None:
        if self._failure is not None:
            failure, self._failure = self._failure, None
            raise ConfigError(f"--ros2: {failure}")

    def _wants(self, topic: str) -> bool:
        out = self._out.get(topic)
        return out is None or (out.ok and (out.latched or out.connections > 0))

    def _send(self, topic: str, msg: Any) -> None:
        out = self._out.get(topic) or self._advertise(topic, msg)
        if not out.ok or not (out.latched or out.connections > 0):
            return
        try:
            data = serialize(self.topic_map.to_ros(topic, msg))
        except (TypeError, ValueError, KeyError, AttributeError) as exc:
            out.ok = False
            self.log.warning("not bridging %s to ROS 2: %s", topic, exc)
            return
        # sent at the next drain; of a topic whose readers keep one message (/clock) only the newest of a batch goes
        if self._side.add(out.id, data, latest_only=out.depth == 1 and not out.latched):
            self.sent += 1

    def _advertise(self, topic: str, msg: Any) -> _Outbound:
        ros_topic = self.topic_map.ros_name(topic)
        latched = self.sim.bus.is_latched(topic)
        try:
            msgtype = msgtype_of(msg)
        except TypeError:
            msgtype = ""
        out = _Outbound(len(self._by_id) + 1, ros_topic or topic, msgtype, latched)
        self._out[topic] = self._by_id[out.id] = out
        if ros_topic is None or not msgtype:
            out.ok = False  # not bridged (the topic map leaves it out, or it is no ROS message)
            return out
        profile = qos.profile(ros_topic, msgtype, latched, self.topic_map.qos_name(ros_topic))
        out.depth = profile["depth"]
        self._side.send_control(op="advertise", id=out.id, topic=ros_topic, type=msgtype, qos=profile)
        return out

    # --- ROS -> sim (frames: BusBridge._on_frame) -----------------------------------------------------------------
    def _on_ready(self, op: dict[str, Any]) -> None:
        self.fully_qualified_name = op.get("name", self.fully_qualified_name)

    def _on_failure(self, op: dict[str, Any]) -> bool:
        if op.get("kind") != "domain":
            return False
        self._failure = op["text"]  # the sim's thread raises it (start(), or the next drain)
        return True

    def _handle(self, item: tuple[Any, ...]) -> None:
        if item[0] == "msg":
            inbound = self._in.get(item[1])
            if inbound is None:
                return
            try:
                msg = deserialize(item[2], inbound.msgtype)
            except (ValueError, KeyError, TypeError, UnicodeDecodeError) as exc:
                if inbound.topic not in self._warned:  # one warning per topic, not one per message
                    self._warned.add(inbound.topic)
                    self.log.warning(
                        "dropped a message on %s from ROS 2 (and will drop any such): %s", inbound.ros_topic, exc
                    )
                return
            self._inject(inbound.topic, self.topic_map.from_ros(inbound.topic, msg), "ROS 2")
        else:
            self._answer(item[1])

    def _answer(self, op: dict[str, Any]) -> None:
        service = self._services.get(op["service"])
        try:
            if service is None:
                raise LookupError(f"the sim no longer offers {op['service']}")
            response = self.sim.bus.call(service.sim_name, service.request(op["request"]))
            self._side.send_control(op="reply", call=op["call"], response=service.response(response, op["request"]))
        except Exception as exc:
            self._side.send_control(op="reply", call=op["call"], error=f"{type(exc).__name__}: {exc}")

    # --- what to subscribe to and offer -------------------------------------------------------------------------
    def _sync(self) -> None:
        """Subscribe on ROS 2 to topics the sim's nodes newly take commands on; follow services offered and gone."""
        for topic, declared in self.sim.bus.listened().items():
            if topic in self._subscribed or declared is None:  # None: the sim's own data (/scan for a driver)
                continue
            self._subscribed.add(topic)
            ros_topic = self.topic_map.ros_name(topic)
            try:
                msgtype = msgtype_of(declared)
            except TypeError:
                continue
            if ros_topic is None:
                continue
            sub_id = len(self._in) + 1
            self._in[sub_id] = _Inbound(topic, ros_topic, msgtype)
            self._side.send_control(op="subscribe", id=sub_id, topic=ros_topic, type=msgtype, qos=qos.command_profile())
        offered = services.offered(self.sim.bus.services())
        for name in set(self._services) - set(offered):
            del self._services[name]
            self._side.send_control(op="unservice", name=name)
        for name, service in offered.items():
            if name not in self._services:
                self._services[name] = service
                self._side.send_control(op="service", name=name, type=service.ros_type)
