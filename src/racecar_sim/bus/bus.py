"""A synchronous, deterministic publish/subscribe bus with ROS topic names.

publish() delivers to every subscriber of the topic, in subscription order, before it returns; a
callback that publishes in turn is served depth-first. There are no threads and no queues, so a run
is a pure function of its inputs.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, Protocol

Callback = Callable[[Any], None]
Tap = Callable[[str, Any], None]
CdrTap = Callable[[str, type, bytes], None]
"""``cdr_tap(topic, message class, CDR bytes)``: a tap that takes a message as its serialized bytes (a recorder)."""


class RowPacker(Protocol):
    """What packs messages of one shape from their numbers (msgs.CdrLayout): ``pack_many(rows)``, the CDR bytes of
    each row's message."""

    def pack_many(self, rows: Sequence[Sequence[Any]], /) -> list[bytes]: ...


FedRows = tuple[type, RowPacker, tuple[str, ...], list[tuple[Any, ...]]]
"""What a feeding subscriber would have published in turn, for publish_fed_rows(): (message class, packer, topics,
rows), as publish_cdr_rows() takes them."""

CdrRowsTap = Callable[[type, RowPacker, tuple[str, ...], list[tuple[Any, ...]]], None]
"""``cdr_rows(message class, packer, topics, rows)``: such a tap taking several messages of one class, published at
one moment, as their numbers (one row per topic, in order) and what packs them: it packs them when it writes them (a
writer process), in one call."""


@dataclass
class Subscription:
    """Handle of one subscription; call unsubscribe() to stop receiving."""

    bus: Bus
    topic: str
    callback: Callback
    feeds: tuple[tuple[str, type], ...] = ()  # (topic, message class) it publishes one message on per message
    msgtype: type | None = None  # the message class it declared it takes (it checks what it gets)
    passive: bool = False  # it takes what others make a topic carry, and makes nothing be published (overhear)

    def unsubscribe(self) -> None:
        self.bus._unsubscribe(self)


@dataclass(slots=True)
class _Topic:
    msgtype: type | None = None
    subscribers: list[Subscription] = field(default_factory=list)
    latched: bool = False
    last: Any = None
    count: int = 0
    declared: type | None = None  # the message class a subscriber said it takes (what a bridge subscribes as)
    callbacks: tuple[Callback, ...] = ()  # the subscribers' callbacks, rebuilt when they change: publish copies nothing
    plain: bool = False  # a subscriber that listens for itself (not only to feed other topics, not overhearing)
    overheard: bool = False  # an overhearing subscriber: it takes message objects whenever they are made
    feeds: tuple[tuple[str, type], ...] = ()  # what the other subscribers publish per message

    def refresh(self) -> None:
        self.callbacks = tuple(sub.callback for sub in self.subscribers)
        self.plain = any(not sub.feeds and not sub.passive for sub in self.subscribers)
        self.overheard = any(sub.passive for sub in self.subscribers)
        self.feeds = tuple(feed for sub in self.subscribers for feed in sub.feeds)


@dataclass
class _Tap:
    callback: Tap
    wants: Callable[[str], bool] | None
    cdr: CdrTap | None = None  # how it takes a message's CDR bytes instead of the message (None: it does not)
    cdr_rows: CdrRowsTap | None = None  # how it takes several as their numbers (None: one cdr() call each)


def type_name(msg_or_cls: object) -> str:
    """A message's or message class's ROS name (std_msgs/String); for anything else, its Python class name."""
    cls = msg_or_cls if isinstance(msg_or_cls, type) else type(msg_or_cls)
    msgtype = getattr(cls, "__msgtype__", None)
    return msgtype.replace("/msg/", "/") if isinstance(msgtype, str) else cls.__name__


class ServiceError(LookupError):
    """A call to a service nobody offers."""


class Bus:
    """Topics by name; latched topics (like /tf_static) hand their last message to late subscribers.

    Services (ROS request/response, e.g. /racecar/controller_manager/list_controllers) are offered with
    advertise_service() and answered synchronously by call(), like everything else on the bus.
    """

    def __init__(self) -> None:
        self._topics: dict[str, _Topic] = {}
        self._taps: list[Tap] = []
        self._tap_entries: list[_Tap] = []
        self._all_taps = False  # a tap without `wants` listens to every topic
        self._object_taps_all = False  # a tap without `wants` that takes only message objects
        self._cdr_entries: tuple[_Tap, ...] = ()  # the taps that take CDR bytes
        self._epoch = 0  # changes with every subscription, overhearing subscriber and tap that comes or goes
        self._wanting = False  # a tap decides which topics it wants (`wants`): its answers may change at any time
        self._services: dict[str, Callable[[Any], Any]] = {}

    def advertise_service(self, name: str, handler: Callable[[Any], Any]) -> None:
        """Offer service `name`: call(name, request) returns handler(request)."""
        if not name.startswith("/"):
            raise ValueError(f"service '{name}' must be absolute (start with '/')")
        if name in self._services:
            raise ValueError(f"service {name} is already offered")
        self._services[name] = handler

    def unadvertise_service(self, name: str) -> None:
        """Stop offering service `name` (a model deleted at run time takes its services with it)."""
        self._services.pop(name, None)

    def call(self, name: str, request: Any) -> Any:
        """Call service `name` with `request` and return its response; ServiceError if nobody offers it."""
        handler = self._services.get(name)
        if handler is None:
            raise ServiceError(f"no service {name} (offered: {', '.join(sorted(self._services)) or 'none'})")
        return handler(request)

    def services(self) -> list[str]:
        """The names of the services offered, sorted."""
        return sorted(self._services)

    def _topic(self, name: str) -> _Topic:
        if not name.startswith("/"):
            raise ValueError(f"topic '{name}' must be absolute (start with '/')")
        return self._topics.setdefault(name, _Topic())

    def latch(self, topic: str) -> None:
        """Mark a topic latched (ROS 1 latch / ROS 2 transient-local)."""
        self._topic(topic).latched = True

    def publish(self, topic: str, msg: Any) -> None:
        """Deliver `msg` to the topic's subscribers and taps now."""
        t = self._topics.get(topic) or self._topic(topic)
        if type(msg) is not t.msgtype:
            if t.declared is not None and type(msg) is not t.declared:
                # not what the topic's nodes take: it goes only to those that declared a class (they drop it with a
                # warning, as a ROS subscriber refuses a publisher of another type); it is not counted, recorded or
                # bridged, and the topic keeps taking the declared class
                for sub in list(t.subscribers):
                    if sub.msgtype is not None:
                        sub.callback(msg)
                return
            if t.msgtype is not None:
                raise TypeError(f"topic {topic} carries {t.msgtype.__name__}, got {type(msg).__name__}")
            t.msgtype = type(msg)
        t.count += 1
        if t.latched:
            t.last = msg
        if self._taps:
            for tap in self._taps:
                tap(topic, msg)
        for callback in t.callbacks:  # those subscribed when delivery began, as a copy of the list would be
            callback(msg)

    def tally(self, topic: str, msgtype: type) -> None:
        """Count a message of class `msgtype` on `topic` that nobody would receive (has_listeners() is False), without
        the message being made: topics() and count() read as if it had been published. Not for a latched topic (a
        late subscriber would get its last message)."""
        t = self._topics.get(topic) or self._topic(topic)
        if t.latched:
            raise ValueError(f"topic {topic} is latched: publish its messages")
        if t.msgtype is None:
            t.msgtype = msgtype
        elif msgtype is not t.msgtype:
            raise TypeError(f"topic {topic} carries {t.msgtype.__name__}, got {msgtype.__name__}")
        t.count += 1
        for feed, feed_type in t.feeds:  # what its subscribers would have published in turn, unheard as well
            self.tally(feed, feed_type)

    def sole_taker(self, topic: str, rows: bool = False) -> Callback | None:
        """The callback of `topic`'s one subscriber where it alone would take a message published there now: one plain
        subscriber (not feeding other topics, not overhearing), no tap, the topic not latched; else None. A publisher
        may then hand it what it takes straight and count the message with delivered(), as long as listeners_epoch()
        stays what it was (a tap or another subscriber that comes gets messages again).

        `rows`: taps may want the topic too, as long as each takes rows (cdr_rows: a recorder); the publisher then
        hands them the message's numbers with publish_cdr_rows() (which counts it) besides handing the subscriber what
        it takes."""
        if self._taps and (not rows or self._object_taps_all):
            return None
        t = self._topics.get(topic)
        if t is None or t.latched or len(t.subscribers) != 1 or not t.plain:
            return None
        if self._taps and not all(
            e.cdr_rows is not None for e in self._tap_entries if e.wants is None or e.wants(topic)
        ):
            return None
        return t.callbacks[0]

    def sole_feeder(self, topic: str) -> Callback | None:
        """The callback of `topic`'s one subscriber where it only turns each message into messages on other topics
        (`feeds`: robot_state_publisher, a joint state into /tf), each of which only taps that take CDR bytes would take
        (cdr_only), and where only taps that take rows (`cdr_rows`: a recorder) take `topic` besides it; the topic
        not latched; else None. A publisher may then hand the taps its message and what that subscriber would have
        made of it as rows, with publish_fed_rows(), as long as listeners_epoch() stays what it was."""
        if not self._cdr_entries or self._object_taps_all:
            return None
        t = self._topics.get(topic)
        if t is None or t.latched or len(t.subscribers) != 1 or t.plain or t.overheard or not t.feeds:
            return None
        if not self._taps_take_bytes(topic, rows=True) or not all(self.cdr_only(feed) for feed, _ in t.feeds):
            return None
        return t.callbacks[0]

    def publish_fed_rows(
        self,
        msgtype: type,
        packer: RowPacker,
        topics: tuple[str, ...],
        rows: list[tuple[Any, ...]],
        fed: Sequence[FedRows],
    ) -> None:
        """publish_cdr_rows() of messages on `topics`, where sole_feeder() gave each topic's subscriber, followed by
        what those subscribers would have published in turn, `fed`: (message class, packer, topics, rows) each, in
        order, as publish_cdr_rows() too. The taps get them in the order publish() would give them; each topic
        counts its messages (the fed topics theirs, instead of a tally)."""
        self.delivered(topics, msgtype)
        self._hand_rows(msgtype, packer, topics, rows)
        for fed_type, fed_packer, fed_topics, fed_rows in fed:
            self.publish_cdr_rows(fed_type, fed_packer, fed_topics, fed_rows)

    def delivered(self, topics: Sequence[str], msgtype: type) -> None:
        """Count a message of class `msgtype` on each of `topics`, handed by its publisher to the topic's sole_taker()
        itself (no message made): topics() and count() read as if each had been published."""
        known = self._topics
        for topic in topics:
            t = known[topic]
            if msgtype is not t.msgtype:
                if t.msgtype is not None:
                    raise TypeError(f"topic {topic} carries {t.msgtype.__name__}, got {msgtype.__name__}")
                t.msgtype = msgtype
            t.count += 1

    def subscribe(
        self, topic: str, callback: Callback, msgtype: type | None = None, feeds: Mapping[str, type] | None = None
    ) -> Subscription:
        """Call `callback(msg)` for every message on `topic`; a latched topic's last message is delivered at once.

        `msgtype`: the message class the subscriber takes, declared by nodes that take commands from outside (the
        muxes' inputs, the controllers' commands) so that a bridge can subscribe to them before anyone publishes.
        A message of another class on that topic reaches only the subscribers that declared one (they check it).
        `feeds` ({topic: message class}), for a node that only turns each message into one message on each of those
        topics (robot_state_publisher: a joint state into a /tf message): it listens only while someone listens
        there (has_listeners), and a message tallied on `topic` is tallied there too. No cycles.
        """
        t = self._topic(topic)
        if msgtype is not None:
            t.declared = msgtype
        sub = Subscription(self, topic, callback, tuple((feeds or {}).items()), msgtype)
        t.subscribers.append(sub)
        t.refresh()
        self._epoch += 1
        if t.latched and t.last is not None:
            callback(t.last)
        return sub

    def overhear(self, topic: str, callback: Callback) -> Subscription:
        """Call `callback(msg)` for every message on `topic` that is published because someone else listens: an
        overhearing subscriber does not count for has_listeners(), so a sensor nobody else reads skips its work (a
        run's log keeping the last camera frame for its summary, while a recording or a video takes every frame)."""
        t = self._topic(topic)
        sub = Subscription(self, topic, callback, passive=True)
        t.subscribers.append(sub)
        t.refresh()
        self._epoch += 1
        if t.latched and t.last is not None:
            callback(t.last)
        return sub

    def tap(
        self,
        callback: Tap,
        wants: Callable[[str], bool] | None = None,
        cdr: CdrTap | None = None,
        cdr_rows: CdrRowsTap | None = None,
    ) -> Callable[[], None]:
        """Call `callback(topic, msg)` for every message on every topic (recorders, bridges); returns a remover.

        `wants(topic)`: whether this tap needs the topic's messages made at all (a bridge: whether a ROS node
        subscribes); has_listeners() asks it, so a sensor nobody reads skips its work. Without it, every topic.
        `cdr(topic, message class, data)`: the tap also takes a message as its CDR bytes (a recorder). A publisher
        whose only takers are such taps (cdr_only()) hands them the bytes with publish_cdr(), made straight from
        its numbers, and no message object is made. `cdr_rows(message class, packer, topics, rows)`, beside `cdr`:
        how it takes the messages of a publish_cdr_rows() in one call, unpacked.
        """
        entry = _Tap(callback, wants, cdr, cdr_rows if cdr is not None else None)
        self._taps.append(callback)
        self._tap_entries.append(entry)
        self._retap()

        def remove() -> None:
            self._taps.remove(callback)
            self._tap_entries.remove(entry)
            self._retap()

        return remove

    def _retap(self) -> None:
        entries = self._tap_entries
        self._all_taps = any(e.wants is None for e in entries)
        self._object_taps_all = any(e.wants is None and e.cdr is None for e in entries)
        self._cdr_entries = tuple(e for e in entries if e.cdr is not None)
        self._wanting = any(e.wants is not None for e in entries)
        self._epoch += 1

    def _unsubscribe(self, sub: Subscription) -> None:
        t = self._topics[sub.topic]
        if sub in t.subscribers:
            t.subscribers.remove(sub)
            t.refresh()
            self._epoch += 1

    def topics(self) -> dict[str, type | None]:
        """Every topic seen so far and its message class."""
        return {name: t.msgtype for name, t in sorted(self._topics.items())}

    def listeners_epoch(self) -> int | None:
        """A number that changes whenever has_listeners() or cdr_only() may answer differently for some topic (a
        subscriber or a tap came or went), for a publisher that keeps their answers while it stays the same; None
        while a tap decides by itself which topics it wants (a bridge: its answers may change at any time)."""
        return None if self._wanting else self._epoch

    def has_listeners(self, topic: str) -> bool:
        """Whether a message on `topic` would reach anyone: a subscriber or a tap (a recorder, a bridge).

        Sensors check this before doing expensive work, as gazebo_ros plugins render only for subscribers.
        """
        if self._all_taps:
            return True
        t = self._topics.get(topic)
        if t is not None and t.callbacks and (t.plain or any(self.has_listeners(feed) for feed, _ in t.feeds)):
            return True
        # no tap without `wants` here (_all_taps is False)
        return bool(self._tap_entries) and any(e.wants(topic) for e in self._tap_entries if e.wants is not None)

    def cdr_only(self, topic: str) -> bool:
        """Whether a message on `topic` would reach only taps that take its CDR bytes (a recorder): then
        publish_cdr() hands them the bytes and no message object is needed. False when nobody listens at all, when a
        subscriber (an overhearing one too, or one feeding a topic someone listens to) would take it, and when a tap
        that takes message objects wants it."""
        if not self._cdr_entries or self._object_taps_all:
            return False
        t = self._topics.get(topic)
        if t is not None and t.callbacks:
            if t.plain or t.overheard or any(self.has_listeners(feed) for feed, _ in t.feeds):
                return False
        return self._taps_take_bytes(topic)

    def _taps_take_bytes(self, topic: str, rows: bool = False) -> bool:
        """Whether a tap wants `topic` and every tap that wants it takes CDR bytes (`rows`: as rows too, cdr_rows)."""
        heard = False
        for e in self._tap_entries:
            if e.wants is None or e.wants(topic):
                if (e.cdr_rows if rows else e.cdr) is None:
                    return False
                heard = True
        return heard

    def publish_cdr(self, topic: str, msgtype: type, data: bytes) -> None:
        """Publish a message of class `msgtype` as its CDR bytes `data` (encapsulation header included), where
        cdr_only(topic) says its only takers are taps that take bytes: they get `data`, and the topic counts it as
        publish() would (what its subscribers would have published in turn is tallied, unheard). Not for a latched
        topic (a late subscriber would get its last message)."""
        self._count_cdr((topic,), msgtype)
        for e in self._cdr_entries:
            if e.wants is None or e.wants(topic):
                e.cdr(topic, msgtype, data)  # type: ignore[misc]  # a _cdr_entries entry has one

    def _count_cdr(self, topics: tuple[str, ...], msgtype: type) -> None:
        """Count a message of class `msgtype` published as bytes on each of `topics`, as publish() would (and tally what
        their feeds would have published); a latched topic or another class on a topic is refused."""
        known = self._topics
        for topic in topics:
            t = known.get(topic)
            if t is None or msgtype is not t.msgtype or t.latched or t.feeds:  # else the usual case: only a count
                t = t or self._topic(topic)
                if t.latched:
                    raise ValueError(f"topic {topic} is latched: publish its messages")
                if msgtype is not t.msgtype:
                    if t.msgtype is not None:
                        raise TypeError(f"topic {topic} carries {t.msgtype.__name__}, got {msgtype.__name__}")
                    t.msgtype = msgtype
                for feed, feed_type in t.feeds:
                    self.tally(feed, feed_type)
            t.count += 1

    def publish_cdr_rows(
        self, msgtype: type, packer: RowPacker, topics: tuple[str, ...], rows: list[tuple[Any, ...]]
    ) -> None:
        """publish_cdr() of a message of class `msgtype` on each of `topics`, in order, published at one moment (a
        car's controller states), given as their numbers: `rows[k]` is the message on `topics[k]`, whose bytes are
        packer.pack_many(rows)[k]. cdr_only() holds for each topic, or sole_taker(topic, rows=True) gave the subscriber
        that its publisher hands the message itself. A tap that takes rows (cdr_rows) gets them in one
        call, unpacked (it may pack them later: the rows, tuples of numbers, are not to be changed after); any other
        gets the bytes, packed once. Each tap gets them in their order (taps are served one after the other, not
        message by message)."""
        self._count_cdr(topics, msgtype)
        self._hand_rows(msgtype, packer, topics, rows)

    def _hand_rows(
        self, msgtype: type, packer: RowPacker, topics: tuple[str, ...], rows: list[tuple[Any, ...]]
    ) -> None:
        """publish_cdr_rows()' messages to the taps, counted already."""
        packed: list[bytes] | None = None
        for e in self._cdr_entries:
            wants = e.wants
            wanted = range(len(topics)) if wants is None else [k for k, topic in enumerate(topics) if wants(topic)]
            if not wanted:
                continue
            if e.cdr_rows is not None:
                if wants is None:
                    e.cdr_rows(msgtype, packer, topics, rows)
                else:
                    e.cdr_rows(msgtype, packer, tuple(topics[k] for k in wanted), [rows[k] for k in wanted])
                continue
            if packed is None:
                packed = packer.pack_many(rows)
            for k in wanted:
                e.cdr(topics[k], msgtype, packed[k])  # type: ignore[misc]  # a _cdr_entries entry has one

    def listened(self) -> dict[str, type | None]:
        """Every topic with a subscriber, and the message class a subscriber declared for it (None: none did)."""
        return {name: t.declared for name, t in sorted(self._topics.items()) if t.subscribers}

    def is_latched(self, topic: str) -> bool:
        """Whether `topic` is latched (its last message goes to late subscribers)."""
        return topic in self._topics and self._topics[topic].latched

    def count(self, topic: str) -> int:
        """How many messages have been published on `topic`."""
        return self._topics[topic].count if topic in self._topics else 0

    def latched_messages(self) -> dict[str, object]:
        """The last message of every latched topic that has one (what a late recorder must write first)."""
        return {name: t.last for name, t in sorted(self._topics.items()) if t.latched and t.last is not None}
