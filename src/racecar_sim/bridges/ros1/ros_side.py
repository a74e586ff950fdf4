"""The ROS 1 side of racecar-sim's bridge: a rospy node, run under the interpreter that has rospy.

The sim (racecar_sim.bridges.ros1.bridge.RosBridge) starts it as `<ros python> ros_side.py --name NODE` and talks
to it over its stdin and stdout; it imports nothing from racecar_sim (that package is not installed for the ROS
interpreter), only the standard library and rospy, genpy and genmsg. `ros_side.py --generate DEFS OUT` instead
generates Python message packages from the `.msg`/`.srv` folders under DEFS into OUT, as catkin's genpy step does.

Frames, both ways: a little-endian uint32 length of what follows, one byte of kind, the payload.
  CONTROL (0): a pickled dict with an "op" (protocol 4).
  DATA (1): a uint32 id (the topic's, given by the sim's advertise or subscribe) and the ROS 1 message bytes.
  BATCH (2, sim -> ROS): DATA frames back to back, each with its length and kind (one pipe write for many).
Sim -> ROS ops: advertise {id, topic, type, latch}, subscribe {id, topic, type}, service {name, type},
  unservice {name}, reply {call, data | error}, shutdown.
ROS -> sim ops: ready {name}, connections {id, count}, call {call, service, data}, error {text}.
Messages are never converted here: publishers and subscribers use classes that carry the real type's _type,
_md5sum and _full_text but hold the raw bytes, so rospy checks the types and nothing is deserialized twice.
"""

from __future__ import annotations  # the ROS interpreter may be older than the sim's (annotations stay text)

import argparse
import importlib
import os
import pickle
import struct
import sys
import threading
import time
from collections.abc import Callable
from typing import IO, TYPE_CHECKING, Any

if TYPE_CHECKING:  # the ROS interpreter's packages (no type information: Any to mypy)
    import genpy
    import rospy

CONTROL, DATA, BATCH = 0, 1, 2
_HEAD = struct.Struct("<IB")
_ID = struct.Struct("<I")
_U32 = struct.Struct("<I")  # the length before each message on a TCPROS connection
_SUB = struct.Struct("<IBI")  # a DATA frame's head inside a BATCH: length of what follows, kind, topic id
CONNECTION_POLL = 0.05  # s between checks of how many ROS subscribers each publisher has
PIPE_SIZE = 1 << 20  # bytes the pipe from the sim holds (Linux's default is 64 KiB): the sim waits less on this node
_F_SETPIPE_SZ = 1031  # fcntl.F_SETPIPE_SZ (named in fcntl from Python 3.10)


def _real_class(ros_type: str, kind: str = "msg") -> type[Any]:
    package, name = ros_type.split("/")
    cls: type[Any] = getattr(importlib.import_module(f"{package}.{kind}"), name)
    return cls


def _raw_class(real: type[Any]) -> type[Any]:
    """A message class with `real`'s identity whose instances hold the serialized bytes."""
    import genpy

    class Raw(genpy.Message):  # genpy has no type information: its Message is Any
        __slots__ = ("data",)
        _type, _md5sum, _full_text, _has_header = real._type, real._md5sum, real._full_text, False
        _slot_types: list[str] = []

        def __init__(self, data: bytes = b"") -> None:
            self.data = data

        def serialize(self, buff: IO[bytes]) -> None:
            buff.write(self.data)

        def deserialize(self, data: bytes) -> Raw:
            self.data = bytes(data)
            return self

    return Raw


_PUBLISHER_IMPL = ("publock", "closed", "is_latch", "latch", "connections", "seq", "message_data_sent")


def _sender(pub: rospy.Publisher, cls: type[Any]) -> Callable[[bytes], None]:
    """A function that publishes one message's bytes on `pub`.

    rospy's Publisher.publish checks its arguments, serializes the message into a buffer with the length before it
    and copies the buffer out, once per message; the bytes here are serialized already. So where the publisher is
    the rospy this was written for (Noetic's, final), the message goes straight to each subscriber's connection as
    _PublisherImpl.publish puts it there (length-prefixed; the latch kept, the count kept, a failed connection
    closed); elsewhere through Publisher.publish.
    """
    impl = getattr(pub, "impl", None)
    if impl is None or not all(hasattr(impl, name) for name in _PUBLISHER_IMPL):
        return lambda data: pub.publish(cls(data))
    pack = _U32.pack

    def send(data: bytes) -> None:
        failed = []
        lock = impl.publock
        if lock is None:  # closed (rospy drops the lock then)
            return
        with lock:
            if impl.closed:
                return
            if impl.is_latch:
                impl.latch = cls(data)
            connections = impl.connections
            if not connections:
                return
            impl.seq += 1
            framed = pack(len(data)) + data
            for connection in connections:
                try:
                    connection.write_data(framed)
                except Exception:  # as rospy: a connection that fails is closed, the others go on
                    failed.append(connection)
            impl.message_data_sent += len(framed)
        for connection in failed:
            try:
                connection.close()  # it removes itself from the publisher
            except Exception:
                pass

    return send


def _raw_service(ros_type: str) -> type[Any]:
    real = _real_class(ros_type, "srv")

    class RawService:
        _type, _md5sum = real._type, real._md5sum
        _request_class = _raw_class(real._request_class)
        _response_class = _raw_class(real._response_class)

    return RawService


class Link:
    """The framed pipe to the sim: reads on the main thread, writes from any thread."""

    def __init__(self, inp: IO[bytes], out: IO[bytes]) -> None:
        self.inp, self.out = inp, out
        self.lock = threading.Lock()

    def send(self, kind: int, payload: bytes) -> None:
        with self.lock:
            self.out.write(_HEAD.pack(len(payload) + 1, kind))
            self.out.write(payload)
            self.out.flush()

    def send_control(self, **fields: object) -> None:
        self.send(CONTROL, pickle.dumps(fields, protocol=4))

    def read(self) -> tuple[int | None, bytes | None]:
        head = self._exact(_HEAD.size)
        if head is None:
            return None, None
        size, kind = _HEAD.unpack(head)
        return kind, self._exact(size - 1)

    def _exact(self, n: int) -> bytes | None:
        chunks, left = [], n
        while left:
            chunk = self.inp.read(left)
            if not chunk:
                return None
            chunks.append(chunk)
            left -= len(chunk)
        return b"".join(chunks)


class _Call:
    """A ROS service call waiting for the sim's reply (set before `answered`)."""

    def __init__(self) -> None:
        self.answered = threading.Event()
        self.reply: dict[str, Any] | None = None


class RosSide:
    """The node: publishers, subscribers and services that forward bytes to and from the sim."""

    def __init__(self, link: Link) -> None:
        import rospy

        self.rospy, self.link = rospy, link
        self.name = rospy.get_name()
        self.publishers: dict[int, tuple[rospy.Publisher, type[genpy.Message]]] = {}
        self.senders: dict[int, Callable[[bytes], None]] = {}  # id -> publish these message bytes
        self.counts: dict[int, int] = {}  # id -> connections last reported
        self.subscribers: list[rospy.Subscriber] = []
        self.subscribed: set[str] = set()  # resolved names of the topics subscribed to
        self.services: dict[str, rospy.Service] = {}
        self.calls: dict[int, _Call] = {}
        self.next_call = 0
        self.lock = threading.Lock()

    def handle(self, op: dict[str, Any]) -> None:
        name = op["op"]
        if name == "advertise":
            cls = _raw_class(_real_class(op["type"]))
            pub = self.rospy.Publisher(op["topic"], cls, latch=op["latch"], queue_size=op.get("queue_size", 10))
            self.publishers[op["id"]] = (pub, cls)
            self.senders[op["id"]] = _sender(pub, cls)
        elif name == "subscribe":
            cls = _raw_class(_real_class(op["type"]))
            self.subscribers.append(self.rospy.Subscriber(op["topic"], cls, self._on_message, op["id"]))
            self.subscribed.add(self.rospy.resolve_name(op["topic"]))
        elif name == "service":
            if op["name"] not in self.services:
                srv = _raw_service(op["type"])

                def handler(request: genpy.Message, name: str = op["name"], srv: type[Any] = srv) -> genpy.Message:
                    return self._on_call(name, srv, request)

                self.services[op["name"]] = self.rospy.Service(op["name"], srv, handler)
        elif name == "unservice":
            service = self.services.pop(op["name"], None)
            if service is not None:
                service.shutdown("the sim no longer offers it")
        elif name == "reply":
            waiting = self.calls.get(op["call"])
            if waiting is not None:
                waiting.reply = op
                waiting.answered.set()

    def publish(self, payload: bytes) -> None:
        (topic_id,) = _ID.unpack_from(payload)
        entry = self.publishers.get(topic_id)
        if entry is not None:  # None: its advertise failed, and the sim was told
            entry[0].publish(entry[1](payload[_ID.size :]))

    def publish_batch(self, payload: bytes) -> None:
        """Each DATA frame of a BATCH payload, in order."""
        senders, unpack, head, pos, end = self.senders, _SUB.unpack_from, _SUB.size, 0, len(payload)
        while pos < end:
            size, _, topic_id = unpack(payload, pos)
            send = senders.get(topic_id)
            if send is not None:  # None: its advertise failed, and the sim was told
                send(payload[pos + head : pos + 4 + size])
            pos += 4 + size

    def _on_message(self, msg: genpy.Message, topic_id: int) -> None:
        header = getattr(msg, "_connection_header", None) or {}
        if header.get("callerid") == self.rospy.get_name():
            return  # what the sim published itself, back through our own subscriber
        self.link.send(DATA, _ID.pack(topic_id) + msg.data)

    def _on_call(self, name: str, srv: type[Any], request: genpy.Message) -> genpy.Message:
        with self.lock:
            self.next_call += 1
            call = self.next_call
            waiting = self.calls[call] = _Call()
        self.link.send_control(op="call", call=call, service=name, data=request.data)
        try:
            while not waiting.answered.wait(0.5):
                if self.rospy.is_shutdown():
                    raise self.rospy.ServiceException("racecar-sim is shutting down")
        finally:
            self.calls.pop(call, None)
        reply = waiting.reply
        assert reply is not None, "a call answered without a reply"
        if reply.get("error"):
            raise self.rospy.ServiceException(reply["error"])
        return srv._response_class(reply["data"])

    def readers(self, pub: rospy.Publisher) -> int:
        """Subscribers of `pub` other than this node (its own subscriber to a topic it also publishes)."""
        try:
            connections = list(pub.impl.connections)
        except AttributeError:  # not the rospy this was written for: count as before
            return max(0, pub.get_num_connections() - (pub.resolved_name in self.subscribed))
        return sum(1 for c in connections if getattr(c, "endpoint_id", None) != self.name)

    def watch_connections(self) -> None:
        """Tell the sim how many subscribers each publisher has, so it serializes only what someone reads."""
        while not self.rospy.is_shutdown():
            for topic_id, (pub, _) in list(self.publishers.items()):
                count = self.readers(pub)
                if self.counts.get(topic_id) != count:
                    self.counts[topic_id] = count
                    self.link.send_control(op="connections", id=topic_id, count=count)
            time.sleep(CONNECTION_POLL)


def _no_sim_time() -> None:
    """This node keeps the wall clock even where /use_sim_time is set: it needs no time of its own, and on sim time
    rospy would subscribe it to the very /clock it publishes (a reader of every /clock message, and a connection
    that made /clock look listened to with nobody else there)."""
    try:
        from rospy.impl import simtime
    except ImportError:
        return
    if hasattr(simtime, "_is_use_simtime"):
        simtime._is_use_simtime = lambda: False


class _Wakes:
    """The sender threads to wake once the batch being published is out (see _batched_connections)."""

    thread: int | None = None  # the thread publishing a batch; None between batches
    pending: list[threading.Condition] = []

    @classmethod
    def publishing(cls) -> None:
        cls.thread = threading.get_ident()

    @classmethod
    def wake(cls) -> None:
        cls.thread = None
        pending, cls.pending = cls.pending, []
        for condition in pending:
            with condition:
                condition.notify()


def _batched_connections() -> None:
    """rospy's publisher queue per subscriber (QueuedConnection), made for batches. Its write_data ended each message
    with time.sleep(0), handing the GIL to the connection's sender thread, and woke that thread for each message: per
    message of a batch, thread switches and waits to get the GIL back. Where it is the rospy this was written for
    (Noetic's, final), write_data here queues the message; a sender waiting on an empty queue is woken at once, or,
    when the message is one of a batch this node publishes, once the whole batch is queued (_Wakes). The senders run
    while this node waits for the next batch (serve() yields once per batch). The queue keeps rospy's rule: full at
    queue_size, it drops the oldest."""
    try:
        from rospy.impl.tcpros_pubsub import QueuedConnection
    except ImportError:
        return
    original = QueuedConnection.write_data

    def write_data(self: Any, data: bytes) -> bool:
        try:
            lock, limit, wake = self._lock, self._queue_size, self._cond_data_available
        except AttributeError:  # another rospy: its own way
            return bool(original(self, data))
        with lock:
            if self._error:
                error, self._error = self._error, None
                raise error
            queue = self._queue
            if limit > 0 and len(queue) >= limit:
                del queue[0]
            queue.append(data)
            if len(queue) == 1:  # the sender waits only on an empty queue
                if _Wakes.thread == threading.get_ident():
                    _Wakes.pending.append(wake)
                else:
                    wake.notify()
        return True

    QueuedConnection.write_data = write_data


def _widen_pipe(fd: int) -> None:
    """Let the pipe on `fd` hold PIPE_SIZE bytes where the system allows it (Linux; up to fs.pipe-max-size)."""
    try:
        import fcntl

        fcntl.fcntl(fd, getattr(fcntl, "F_SETPIPE_SZ", _F_SETPIPE_SZ), PIPE_SIZE)
    except (ImportError, OSError):
        pass  # another system, or a smaller limit: the default size works, with more waits


def serve(name: str) -> None:
    """Run the node until the sim says shutdown or closes the pipe."""
    out = os.fdopen(os.dup(1), "wb")
    os.dup2(2, 1)  # anything rospy prints goes to stderr, never into the frames
    _widen_pipe(0)
    link = Link(os.fdopen(0, "rb", buffering=0), out)
    import rospy

    _no_sim_time()
    rospy.init_node(name, anonymous=False, disable_signals=True)
    _batched_connections()
    node = RosSide(link)
    link.send_control(op="ready", name=rospy.get_name())
    threading.Thread(target=node.watch_connections, daemon=True).start()
    while True:
        kind, payload = link.read()
        if kind is None:
            break
        assert payload is not None, "the pipe closed within a frame"
        if kind == BATCH:
            _Wakes.publishing()
            try:
                node.publish_batch(payload)
            finally:
                _Wakes.wake()
            time.sleep(0)  # the sender threads' turn (see _batched_connections)
            continue
        if kind == DATA:
            node.publish(payload)
            continue
        op = pickle.loads(payload)
        if op["op"] == "shutdown":
            break
        try:
            node.handle(op)
        except Exception as exc:  # a type ROS does not know: report it, keep the rest going
            link.send_control(
                op="error",
                id=op.get("id"),
                kind=op["op"],
                text=f"{op['op']} {op.get('topic') or op.get('name')}: {type(exc).__name__}: {exc}",
            )
    rospy.signal_shutdown("racecar-sim closed the bridge")


# --- message generation ----------------------------------------------------------------------------------------
def _external_types(defs: str, packages: list[str]) -> set[str]:
    """`pkg/Name` types the definitions use from packages other than theirs (std_msgs, geometry_msgs, ...)."""
    import genmsg.msgs

    found: set[str] = set()
    for package in packages:
        for kind in ("msg", "srv"):
            folder = os.path.join(defs, package, kind)
            for fname in sorted(os.listdir(folder)) if os.path.isdir(folder) else ():
                with open(os.path.join(folder, fname)) as f:
                    for line in f:
                        token = line.split("#", 1)[0].split()
                        if len(token) >= 2 and "=" not in line.split("#", 1)[0]:
                            base = genmsg.msgs.bare_msg_type(token[0])
                            if base == "Header":
                                base = "std_msgs/Header"
                            if "/" in base and base.split("/")[0] not in packages:
                                found.add(base)
    return found


def _write_dependencies(types: set[str], folder: str) -> dict[str, list[str]]:
    """The .msg files of types the system has (from its genpy classes' full texts), for genmsg's search path."""
    search: dict[str, list[str]] = {}
    for ros_type in types:
        blocks = _real_class(ros_type)._full_text.split("\n" + "=" * 80 + "\n")
        texts = [(ros_type, blocks[0])] + [(b.split("\n", 1)[0][5:].strip(), b.split("\n", 1)[1]) for b in blocks[1:]]
        for dep_type, text in texts:
            package, name = dep_type.split("/")
            msg_dir = os.path.join(folder, package, "msg")
            os.makedirs(msg_dir, exist_ok=True)
            with open(os.path.join(msg_dir, name + ".msg"), "w") as f:
                f.write(text)
            search[package] = [msg_dir]
    return search


def generate(defs: str, out: str, only: list[str] | None = None) -> int:
    """Generate `<pkg>/msg` and `<pkg>/srv` Python modules under `out` for each package under `defs` the system
    cannot import (or each in `only`)."""
    import genpy.generate_initpy
    import genpy.generator

    packages = sorted(p for p in os.listdir(defs) if os.path.isdir(os.path.join(defs, p)))
    if only is None:
        packages = [p for p in packages if not _importable(p)]
    search = _write_dependencies(_external_types(defs, packages), os.path.join(out, ".deps"))
    for package in packages:
        search[package] = [os.path.join(defs, package, "msg")]
    status = 0
    for package in packages:
        pkg_out = os.path.join(out, package)
        for kind, gen in (("msg", genpy.generator.MsgGenerator()), ("srv", genpy.generator.SrvGenerator())):
            folder = os.path.join(defs, package, kind)
            if not os.path.isdir(folder):
                continue
            files = [os.path.join(folder, f) for f in sorted(os.listdir(folder)) if f.endswith("." + kind)]
            status |= gen.generate_messages(package, files, os.path.join(pkg_out, kind), search)
            genpy.generate_initpy.write_modules(os.path.join(pkg_out, kind))
        with open(os.path.join(pkg_out, "__init__.py"), "w") as f:
            f.write("")
    print("\n".join(packages))
    return status


def _importable(package: str) -> bool:
    try:
        importlib.import_module(package + ".msg")
        return True
    except ImportError:
        return False


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n", 1)[0])
    parser.add_argument("--name", default="racecar_sim", help="the node's name")
    parser.add_argument("--generate", nargs=2, metavar=("DEFS", "OUT"), help="generate message packages and exit")
    args = parser.parse_args(argv)
    if args.generate:
        return generate(*args.generate)
    serve(args.name)
    return 0


if __name__ == "__main__":
    sys.exit(main())
