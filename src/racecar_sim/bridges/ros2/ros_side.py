"""The ROS 2 side of racecar-sim's bridge: an rclpy node (`racecar_sim`), run under the Python that has rclpy.

The sim (racecar_sim.bridges.ros2.bridge.Ros2Bridge) starts it as `<python> ros_side.py --name NODE` and talks to it
over its stdin and stdout with the frames of bridges/link.py (loaded from its path: racecar_sim itself is not
installed for this interpreter; only the standard library and rclpy are used). `ros_side.py --probe` prints what this
interpreter has (distro, Python version, prefix) as one JSON line.

Sim -> ROS ops: advertise {id, topic, type, qos}, subscribe {id, topic, type, qos}, service {name, type},
  unservice {name}, reply {call, response | error}, shutdown; DATA: a publisher's id and the CDR bytes to publish.
ROS -> sim ops: ready {name, distro}, connections {id, count}, call {call, service, request}, error {kind, text};
  DATA: a subscription's id and the CDR bytes it received.
Messages are never converted here: publishers publish the sim's own CDR bytes and subscriptions take raw bytes (rclpy
checks the types and the graph shows them). Service requests and responses, rare and small, cross as plain dicts.
"""

from __future__ import annotations  # the ROS interpreter may be older than the sim's

import argparse
import collections
import importlib
import importlib.util
import json
import os
import pickle
import sys
import threading
import time
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:  # the ROS interpreter's packages (no type information here)
    from rclpy.node import Node

CONNECTION_POLL = 0.05  # s between counts of the subscribers each publisher has
# s after start in which another node of our name in the domain means a domain in use: Fast DDS participants announce
# themselves a few times at start, then every 3 s, so a start-up announcement missed on a loaded machine is made good
# within the window
DUPLICATE_WINDOW = 6.0
ECHO_WINDOW = 2.0  # s a message we published on a topic we subscribe to may take to come back to us
ECHO_KEEP = 1000  # of those messages, at most this many remembered per topic
CALL_TIMEOUT = 30.0  # s a service call waits for the sim's answer (a paused sim still answers between events)
DISTROS_BY_RCLPY = {"3": "humble", "4": "iron", "7": "jazzy", "9": "kilted", "10": "rolling"}


def _link_module() -> Any:
    path = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "link.py")
    spec = importlib.util.spec_from_file_location("racecar_sim_bridge_link", path)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _load(ros_type: str) -> Any:
    """The class of `pkg/msg/Name` or `pkg/srv/Name` (`pkg/Name` is taken as a message)."""
    parts = ros_type.split("/")
    package, kind, name = (parts[0], "msg", parts[1]) if len(parts) == 2 else parts
    return getattr(importlib.import_module(f"{package}.{kind}"), name)


def _qos(spec: dict[str, Any]) -> Any:
    from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

    return QoSProfile(
        history=HistoryPolicy.KEEP_LAST,
        depth=int(spec["depth"]),
        reliability=ReliabilityPolicy.BEST_EFFORT
        if spec["reliability"] == "best_effort"
        else ReliabilityPolicy.RELIABLE,
        durability=DurabilityPolicy.TRANSIENT_LOCAL
        if spec["durability"] == "transient_local"
        else DurabilityPolicy.VOLATILE,
    )


def to_plain(value: Any) -> Any:
    """A message as dicts, lists and plain values."""
    if hasattr(value, "get_fields_and_field_types"):
        return {name: to_plain(getattr(value, name)) for name in value.get_fields_and_field_types()}
    if isinstance(value, (str, bytes, bool, int, float)):
        return value
    try:
        return [to_plain(item) for item in value]
    except TypeError:
        return value


def fill(msg: Any, plain: dict[str, Any]) -> Any:
    """`msg` with the fields of `plain` set (nested messages and arrays of them too)."""
    types = msg.get_fields_and_field_types()
    for name, value in plain.items():
        kind = types[name]
        current = getattr(msg, name)
        if hasattr(current, "get_fields_and_field_types"):
            fill(current, value)
        elif kind.startswith("sequence<") and "/" in kind:
            element = _load(kind[len("sequence<") : -1].split(",")[0])
            setattr(msg, name, [fill(element(), item) for item in value])
        else:
            setattr(msg, name, value)
    return msg


class _Call:
    """A ROS service call waiting for the sim's reply (set before `answered`)."""

    def __init__(self) -> None:
        self.answered = threading.Event()
        self.reply: dict[str, Any] | None = None


class RosSide:
    """The node's publishers, subscriptions and services, forwarding bytes to and from the sim."""

    DATA: int = 1  # the frame kinds and the id header of bridges/link.py (set from it by serve())
    ID: Any = None

    def __init__(self, node: Node, link: Any) -> None:
        self.node, self.link = node, link
        self.publishers: dict[int, Any] = {}
        self.counts: dict[int, int] = {}
        self.subscribed: dict[str, int] = {}  # topic -> subscriptions of ours on it (they match our publishers)
        self.subscriptions: dict[int, Any] = {}
        self.services: dict[str, Any] = {}
        self.calls: dict[int, _Call] = {}
        self.next_call = 0
        self.lock = threading.Lock()
        self.echoes: dict[str, collections.deque[tuple[float, bytes]]] = {}  # what we published on a subscribed topic
        self.echo_lock = threading.Lock()

    def handle(self, op: dict[str, Any]) -> None:
        name = op["op"]
        if name == "advertise":
            pub = self.node.create_publisher(_load(op["type"]), op["topic"], _qos(op["qos"]))
            self.publishers[op["id"]] = pub
        elif name == "subscribe":
            sub_id, topic = op["id"], op["topic"]

            def forward(data: bytes) -> None:
                if topic in self.echoes and self._echo(topic, data):
                    return  # what the sim published itself, back through our own subscription
                self.link.send(self.DATA, self.ID.pack(sub_id), data)

            sub = self.node.create_subscription(_load(op["type"]), op["topic"], forward, _qos(op["qos"]), raw=True)
            self.subscriptions[sub_id] = sub
            self.subscribed[topic] = self.subscribed.get(topic, 0) + 1
            self.echoes.setdefault(topic, collections.deque(maxlen=ECHO_KEEP))
        elif name == "service":
            if op["name"] not in self.services:
                srv = _load(op["type"])

                def handler(request: Any, response: Any, name: str = op["name"]) -> Any:
                    return self._on_call(name, request, response)

                self.services[op["name"]] = self.node.create_service(srv, op["name"], handler)
        elif name == "unservice":
            service = self.services.pop(op["name"], None)
            if service is not None:
                self.node.destroy_service(service)
        elif name == "reply":
            waiting = self.calls.get(op["call"])
            if waiting is not None:
                waiting.reply = op
                waiting.answered.set()

    def _echo(self, topic: str, data: bytes) -> bool:
        """Whether `data` on `topic` is a message we published there ECHO_WINDOW s ago or less (each of ours is taken
        back once). rclpy gives a raw subscription no publisher id, and a subscription cannot ignore its own node's
        publishers: the bytes tell ours (a ROS node sending the very same bytes at the same time loses one message)."""
        now = time.monotonic()
        with self.echo_lock:
            sent = self.echoes[topic]
            while sent and now - sent[0][0] > ECHO_WINDOW:
                sent.popleft()
            for i, (_, payload) in enumerate(sent):
                if payload == data:
                    del sent[i]
                    return True
        return False

    def publish(self, payload: bytes | memoryview) -> None:
        (topic_id,) = self.ID.unpack_from(payload)
        pub = self.publishers.get(topic_id)
        if pub is None:  # its advertise failed, and the sim was told
            return
        data = bytes(payload[self.ID.size :])
        sent = self.echoes.get(pub.topic_name)
        if sent is not None:  # we also subscribe to this topic: remember what comes back
            with self.echo_lock:
                sent.append((time.monotonic(), data))
        pub.publish(data)

    def _on_call(self, name: str, request: Any, response: Any) -> Any:
        with self.lock:
            self.next_call += 1
            call = self.next_call
            waiting = self.calls[call] = _Call()
        self.link.send_control(op="call", call=call, service=name, request=to_plain(request))
        try:
            if not waiting.answered.wait(CALL_TIMEOUT):
                self.node.get_logger().error(f"{name}: racecar-sim did not answer in {CALL_TIMEOUT:g} s")
                return response
        finally:
            self.calls.pop(call, None)
        reply = waiting.reply or {}
        if reply.get("error"):
            self.node.get_logger().error(f"{name}: {reply['error']}")
            return response
        return fill(response, reply.get("response") or {})

    def watch_connections(self, stop: threading.Event) -> None:
        """Tell the sim how many subscribers each publisher has, so it serializes only what someone reads; in the
        first DUPLICATE_WINDOW s, tell it if the domain has another node of our name (discovery takes a moment: a
        sim started earlier shows up here, while that one has long stopped looking and goes on)."""
        looking = time.monotonic() + DUPLICATE_WINDOW
        while not stop.wait(CONNECTION_POLL):
            if looking and time.monotonic() < looking and _duplicates(self.node) > 0:
                looking = 0.0
                domain = os.environ.get("ROS_DOMAIN_ID") or "0"
                self.link.send_control(
                    op="error",
                    kind="domain",
                    text=f"ROS_DOMAIN_ID={domain} already has a node {self.node.get_fully_qualified_name()} "
                    "(another racecar-sim --ros2?): stop it, or give this run another ROS_DOMAIN_ID",
                )
            for topic_id, pub in list(self.publishers.items()):
                try:
                    count = pub.get_subscription_count()
                except Exception:  # destroyed while shutting down
                    return
                count = max(0, count - self.subscribed.get(pub.topic_name, 0))  # ours are no readers
                if self.counts.get(topic_id) != count:
                    self.counts[topic_id] = count
                    self.link.send_control(op="connections", id=topic_id, count=count)


def _duplicates(node: Node) -> int:
    """How many other nodes of this node's name and namespace the graph shows."""
    me = (node.get_name(), node.get_namespace())
    return sum(1 for entry in node.get_node_names_and_namespaces() if tuple(entry) == me) - 1


def serve(name: str) -> int:
    """Run the node until the sim says shutdown or closes the pipe."""
    links = _link_module()
    link = links.PipeEnd.from_stdio()
    RosSide.DATA, RosSide.ID = links.DATA, links.ID
    import rclpy
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.node import Node

    rclpy.init()
    node = Node(name)
    side = RosSide(node, link)
    # one thread: rclpy's MultiThreadedExecutor took commands so slowly beside the publishing that, at 50 Hz from a
    # ROS 2 node, 2 of 5 were never taken (a service call waits for the sim's answer, a drain away, meanwhile)
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    spinner = threading.Thread(target=executor.spin, daemon=True)
    spinner.start()
    stop = threading.Event()
    watcher = threading.Thread(target=side.watch_connections, args=(stop,), daemon=True)
    watcher.start()
    link.send_control(op="ready", name=node.get_fully_qualified_name(), distro=os.environ.get("ROS_DISTRO", ""))
    try:
        while True:
            frame = link.read()
            if frame is None:
                break
            kind, payload = frame
            if kind == links.BATCH:
                for inner_kind, inner in link.frames(payload):
                    if inner_kind == links.DATA:
                        side.publish(inner)
                continue
            if kind == links.DATA:
                side.publish(payload)
                continue
            op = pickle.loads(payload)
            if op["op"] == "shutdown":
                break
            try:
                side.handle(op)
            except Exception as exc:  # a type this ROS does not know: report it, keep the rest going
                link.send_control(
                    op="error",
                    id=op.get("id"),
                    kind=op["op"],
                    text=f"{op['op']} {op.get('topic') or op.get('name')}: {type(exc).__name__}: {exc}",
                )
    finally:
        stop.set()
        watcher.join(1.0)
        rclpy.try_shutdown()  # wakes the executor: spin() returns
        executor.shutdown(timeout_sec=1.0)
        spinner.join(2.0)
        node.destroy_node()
    return 0


def probe(packages: list[str]) -> int:
    """One JSON line: what this interpreter has for ROS 2, and which of `packages` it imports (exit code 1 if rclpy
    does not import)."""
    try:
        import rclpy
        from rclpy.impl.implementation_singleton import rclpy_implementation  # noqa: F401 (the C extension loads)
    except Exception as exc:
        print(f"rclpy: {type(exc).__name__}: {exc}", file=sys.stderr)
        return 1
    from importlib import metadata

    distro, wheels = os.environ.get("ROS_DISTRO", ""), False
    for dist in metadata.distributions():
        dist_name = (dist.metadata["Name"] or "").lower().replace("_", "-")
        if dist_name.startswith("ros-") and dist_name.endswith("-rclpy"):
            wheels = True
            middle = dist_name[len("ros-") : -len("-rclpy")]
            if middle:
                distro = middle
    if not distro:
        try:
            version = metadata.version("rclpy")
        except metadata.PackageNotFoundError:
            version = ""
        distro = DISTROS_BY_RCLPY.get(version.split(".")[0], "unknown")
    print(
        json.dumps(
            {
                "distro": distro,
                "python_version": f"{sys.version_info[0]}.{sys.version_info[1]}",
                "prefix": sys.prefix,
                "rclpy": os.path.dirname(rclpy.__file__),
                "wheels": wheels,
                "has": [p for p in packages if importlib.util.find_spec(p) is not None],
            }
        )
    )
    return 0


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=(__doc__ or "").split("\n", 1)[0])
    parser.add_argument("--name", default="racecar_sim", help="the node's name")
    parser.add_argument(
        "--probe", metavar="PKG,PKG", help="print what this interpreter has (and which of PKG it imports), and exit"
    )
    args = parser.parse_args(argv)
    if args.probe is not None:
        return probe([p for p in args.probe.split(",") if p])
    return serve(args.name)


if __name__ == "__main__":
    sys.exit(main())
