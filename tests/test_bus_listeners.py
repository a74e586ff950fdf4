"""Bus additions for bridges: declared subscriber types (listened) and taps that want only some topics; taps that take
CDR bytes (a recorder), which a publisher hands its bytes alone where nobody else listens (cdr_only, publish_cdr)."""

import pytest

from racecar_sim.bus import Bus
from racecar_sim.msgs import AckermannDriveStamped, Float64


def test_listened_reports_declared_types() -> None:
    bus = Bus()
    bus.subscribe("/cmd", lambda m: None, msgtype=AckermannDriveStamped)
    bus.subscribe("/odom", lambda m: None)
    bus.publish("/other", Float64(1.0))
    assert bus.listened() == {"/cmd": AckermannDriveStamped, "/odom": None}


def test_tap_with_wants_decides_has_listeners() -> None:
    bus = Bus()
    wanted = {"/scan"}
    seen = []
    remove = bus.tap(lambda topic, msg: seen.append(topic), wants=lambda topic: topic in wanted)
    assert bus.has_listeners("/scan") and not bus.has_listeners("/camera/image")
    bus.publish("/camera/image", Float64(0.0))  # a tap still sees what is published anyway
    assert seen == ["/camera/image"]
    plain = bus.tap(lambda topic, msg: None)  # a recorder: every topic
    assert bus.has_listeners("/camera/image")
    plain()
    remove()
    assert not bus.has_listeners("/scan")


def test_an_overhearing_subscriber_gets_what_others_make_published_and_counts_for_nobody() -> None:
    bus = Bus()
    heard: list[float] = []
    sub = bus.overhear("/camera/image", lambda m: heard.append(m.data))
    assert not bus.has_listeners("/camera/image")  # alone, it makes nothing be published
    listener = bus.subscribe("/camera/image", lambda m: None)
    assert bus.has_listeners("/camera/image")
    bus.publish("/camera/image", Float64(2.0))
    assert heard == [2.0]  # what is published for another reaches it too
    listener.unsubscribe()
    assert not bus.has_listeners("/camera/image")
    sub.unsubscribe()
    bus.publish("/camera/image", Float64(3.0))
    assert heard == [2.0]


def test_cdr_only_when_every_taker_takes_cdr_bytes() -> None:
    bus = Bus()
    assert not bus.cdr_only("/state")  # nobody listens
    got: list[tuple[str, type, bytes]] = []
    objects: list[str] = []
    remove = bus.tap(lambda topic, msg: objects.append(topic), cdr=lambda *item: got.append(item))
    assert bus.cdr_only("/state") and bus.has_listeners("/state")
    bus.publish_cdr("/state", Float64, b"\x00\x01\x00\x00" + bytes(8))
    assert got == [("/state", Float64, b"\x00\x01\x00\x00" + bytes(8))] and not objects
    assert bus.count("/state") == 1 and bus.topics()["/state"] is Float64

    sub = bus.subscribe("/state", lambda m: None)  # a subscriber takes the message object
    assert not bus.cdr_only("/state")
    sub.unsubscribe()
    heard = bus.overhear("/state", lambda m: None)  # so does one overhearing it
    assert not bus.cdr_only("/state")
    heard.unsubscribe()
    bridge = bus.tap(lambda topic, msg: None, wants=lambda topic: topic == "/state")  # a tap of objects that wants it
    assert not bus.cdr_only("/state") and bus.cdr_only("/other")
    bridge()
    recorder = bus.tap(lambda topic, msg: None)  # a tap of objects for every topic
    assert not bus.cdr_only("/other")
    recorder()
    assert bus.cdr_only("/other")
    remove()
    assert not bus.cdr_only("/other")


def test_publish_cdr_counts_tallies_feeds_and_refuses_what_publish_would() -> None:
    bus = Bus()
    bus.tap(lambda topic, msg: None, cdr=lambda *item: None)
    bus.subscribe("/joint_states", lambda m: None, feeds={"/tf": AckermannDriveStamped})
    assert not bus.cdr_only("/joint_states")  # its subscriber makes /tf, which the recorder hears
    quiet = Bus()
    quiet.tap(lambda topic, msg: None, cdr=lambda *item: None, wants=lambda topic: topic == "/joint_states")
    quiet.subscribe("/joint_states", lambda m: None, feeds={"/tf": AckermannDriveStamped})
    assert quiet.cdr_only("/joint_states")  # nobody hears /tf: the bytes are enough, /tf is counted unheard
    quiet.publish_cdr("/joint_states", Float64, b"")
    assert quiet.count("/tf") == 1 and quiet.topics()["/tf"] is AckermannDriveStamped
    bus.publish_cdr("/x", Float64, b"")
    with pytest.raises(TypeError, match="carries Float64"):
        bus.publish_cdr("/x", AckermannDriveStamped, b"")
    bus.latch("/latched")
    with pytest.raises(ValueError, match="latched"):
        bus.publish_cdr("/latched", Float64, b"")


class _Packer:
    """Packs a row (a number) as its decimal digits; counts its calls."""

    def __init__(self) -> None:
        self.calls = 0

    def pack_many(self, rows: list[tuple[int, ...]]) -> list[bytes]:
        self.calls += 1
        return [str(row[0]).encode() for row in rows]


def test_publish_cdr_rows_is_publish_cdr_of_each_in_turn() -> None:
    """Each tap gets the messages a publish_cdr() of each would give it, in their order: a tap that takes rows gets
    them in one call, unpacked (one with `wants` only those it wants), the others their bytes, packed once for all;
    every topic is counted."""
    bus = Bus()
    singles: list[tuple[str, type, bytes]] = []
    batches: list[tuple[object, ...]] = []
    wanted: list[tuple[str, type, bytes]] = []
    wanted_rows: list[tuple[object, ...]] = []
    packer = _Packer()
    bus.tap(lambda topic, msg: None, cdr=lambda *item: singles.append(item))
    bus.tap(lambda topic, msg: None, cdr=lambda *item: None, cdr_rows=lambda *batch: batches.append(batch))
    bus.tap(lambda topic, msg: None, wants=lambda topic: topic != "/b", cdr=lambda *item: wanted.append(item))
    bus.tap(
        lambda topic, msg: None, wants=lambda topic: topic != "/a", cdr=print, cdr_rows=lambda *b: wanted_rows.append(b)
    )
    topics, rows = ("/a", "/b", "/a"), [(1,), (2,), (3,)]
    bus.publish_cdr_rows(Float64, packer, topics, rows)
    assert singles == [("/a", Float64, b"1"), ("/b", Float64, b"2"), ("/a", Float64, b"3")]
    assert batches == [(Float64, packer, topics, rows)]
    assert wanted == [("/a", Float64, b"1"), ("/a", Float64, b"3")]
    assert wanted_rows == [(Float64, packer, ("/b",), [(2,)])]
    assert packer.calls == 1
    assert bus.count("/a") == 2 and bus.count("/b") == 1 and bus.topics()["/b"] is Float64
    with pytest.raises(TypeError, match="carries Float64"):
        bus.publish_cdr_rows(AckermannDriveStamped, packer, ("/a",), [(0,)])
    bus.latch("/latched")
    with pytest.raises(ValueError, match="latched"):
        bus.publish_cdr_rows(Float64, packer, ("/latched",), [(0,)])


def test_listeners_epoch_changes_whenever_who_listens_changes() -> None:
    """A publisher may keep has_listeners() and cdr_only() answers while listeners_epoch() stays the same: it changes
    with every subscriber and tap that comes or goes, and is None while a tap decides by itself what it wants."""
    bus = Bus()
    seen = [bus.listeners_epoch()]

    def changed() -> bool:
        epoch = bus.listeners_epoch()
        new = epoch is not None and epoch not in seen
        seen.append(epoch)
        return new

    bus.publish("/a", Float64(1.0))
    bus.latch("/b")
    assert bus.listeners_epoch() == seen[-1]  # publishing and latching change no answer
    sub = bus.subscribe("/a", lambda m: None)
    assert changed() and bus.has_listeners("/a")
    sub.unsubscribe()
    assert changed() and not bus.has_listeners("/a")
    bus.overhear("/a", lambda m: None)
    assert changed()
    remove = bus.tap(lambda topic, msg: None, cdr=lambda *item: None)
    assert changed() and bus.cdr_only("/c")
    remove()
    assert changed() and not bus.has_listeners("/c")
    bus.tap(lambda topic, msg: None, wants=lambda topic: topic == "/c")
    assert bus.listeners_epoch() is None


def test_a_sole_taker_is_one_plain_subscriber_alone_and_delivered_counts_as_publish() -> None:
    """sole_taker() names a topic's subscriber only where nothing else would take a message there: not with a second
    subscriber, an overhearing one, one that feeds another topic, any tap, or a latched topic. delivered() then counts
    the messages its publisher handed over itself, as publish() would have (the count and the class)."""
    bus = Bus()

    def take(msg: object) -> None:
        pass

    assert bus.sole_taker("/cmd") is None  # nobody
    bus.subscribe("/cmd", take, Float64)
    assert bus.sole_taker("/cmd") is take
    bus.delivered(["/cmd", "/cmd"], Float64)
    assert bus.count("/cmd") == 2 and bus.topics()["/cmd"] is Float64
    with pytest.raises(TypeError, match="carries Float64"):
        bus.delivered(["/cmd"], AckermannDriveStamped)
    second = bus.subscribe("/cmd", lambda m: None)
    assert bus.sole_taker("/cmd") is None
    second.unsubscribe()
    heard = bus.overhear("/cmd", lambda m: None)
    assert bus.sole_taker("/cmd") is None
    heard.unsubscribe()
    assert bus.sole_taker("/cmd") is take
    remove = bus.tap(lambda topic, msg: None, wants=lambda topic: topic == "/other")  # any tap: no sole taker
    assert bus.sole_taker("/cmd") is None
    remove()
    remove = bus.tap(lambda topic, msg: None, cdr=lambda *item: None)
    assert bus.sole_taker("/cmd") is None
    remove()
    bus.subscribe("/joint_states", lambda m: None, feeds={"/tf": Float64})
    assert bus.sole_taker("/joint_states") is None  # it feeds another topic: tally and has_listeners look there
    bus.latch("/cmd")
    assert bus.sole_taker("/cmd") is None


def test_a_sole_taker_beside_rows_allows_taps_that_each_take_rows_where_they_want_the_topic() -> None:
    """sole_taker(rows=True) names the one plain subscriber also where taps want the topic, as long as each that wants
    it takes rows (a recorder): not beside a tap taking objects (wanting every topic or this one), nor one taking bytes
    alone; a tap taking objects that wants other topics only leaves it be. The rest is sole_taker()'s."""
    bus = Bus()

    def take(msg: object) -> None:
        pass

    def rows(*item: object) -> None:
        pass

    bus.subscribe("/cmd", take, Float64)
    assert bus.sole_taker("/cmd", rows=True) is take  # no tap: as sole_taker()
    remove = bus.tap(lambda topic, msg: None, cdr=lambda *item: None, cdr_rows=rows)
    assert bus.sole_taker("/cmd", rows=True) is take and bus.sole_taker("/cmd") is None
    for tap in (
        {"cdr": lambda *item: None},  # bytes, not rows
        {},  # objects
        {"wants": lambda topic: topic == "/cmd"},  # objects, of this topic
    ):
        other = bus.tap(lambda topic, msg: None, **tap)  # type: ignore[arg-type]
        assert bus.sole_taker("/cmd", rows=True) is None, tap
        other()
    other = bus.tap(lambda topic, msg: None, wants=lambda topic: topic == "/other")
    assert bus.sole_taker("/cmd", rows=True) is take
    other()
    second = bus.subscribe("/cmd", lambda m: None)
    assert bus.sole_taker("/cmd", rows=True) is None
    second.unsubscribe()
    heard = bus.overhear("/cmd", lambda m: None)
    assert bus.sole_taker("/cmd", rows=True) is None
    heard.unsubscribe()
    bus.latch("/cmd")
    assert bus.sole_taker("/cmd", rows=True) is None
    remove()


def test_a_sole_feeder_is_one_feeding_subscriber_beside_taps_that_take_rows_and_fed_rows_count_as_publish() -> None:
    """sole_feeder() names a topic's subscriber only where it feeds other topics that taps taking bytes alone take,
    and only taps taking rows take the topic beside it: not with a second subscriber, a plain or overhearing one, a
    tap taking objects or bytes one by one, a listener on the fed topic, or a latched topic. publish_fed_rows() then
    hands every tap the messages and the fed ones in publish()'s order and counts each topic once per message."""
    bus = Bus()
    feeds = {"/tf": AckermannDriveStamped}

    def feed(msg: object) -> None:
        pass

    assert bus.sole_feeder("/joint_states") is None  # nobody
    bus.subscribe("/joint_states", feed, feeds=feeds)
    assert bus.sole_feeder("/joint_states") is None  # no recorder: nothing would be made at all
    got: list[object] = []
    remove = bus.tap(lambda topic, msg: None, cdr=lambda *item: None, cdr_rows=lambda *batch: got.append(batch))
    assert bus.sole_feeder("/joint_states") is feed
    packer = _Packer()
    bus.publish_fed_rows(
        Float64, packer, ("/joint_states",), [(1,)], [(AckermannDriveStamped, packer, ("/tf",), [(2,)])]
    )
    assert got == [(Float64, packer, ("/joint_states",), [(1,)]), (AckermannDriveStamped, packer, ("/tf",), [(2,)])]
    assert bus.count("/joint_states") == 1 and bus.count("/tf") == 1  # the fed topic counted once, not tallied too
    assert bus.topics()["/joint_states"] is Float64 and bus.topics()["/tf"] is AckermannDriveStamped
    for other in (
        lambda: bus.subscribe("/tf", lambda m: None),  # someone listens where it feeds: it must make messages
        lambda: bus.overhear("/tf", lambda m: None),
        lambda: bus.subscribe("/joint_states", lambda m: None),  # a plain second subscriber
        lambda: bus.overhear("/joint_states", lambda m: None),
    ):
        sub = other()
        assert bus.sole_feeder("/joint_states") is None
        sub.unsubscribe()
        assert bus.sole_feeder("/joint_states") is feed
    for tap in (
        {"cdr": lambda *item: None},  # bytes one by one
        {},  # objects
        {"wants": lambda topic: topic == "/tf"},  # a bridge whose node takes /tf
        {"wants": lambda topic: topic == "/joint_states", "cdr": lambda *item: None},
    ):
        untap = bus.tap(lambda topic, msg: None, **tap)  # type: ignore[arg-type]
        assert bus.sole_feeder("/joint_states") is None
        untap()
    untap = bus.tap(lambda topic, msg: None, wants=lambda topic: topic == "/other")  # wants neither topic
    assert bus.sole_feeder("/joint_states") is feed
    untap()
    remove()
    bus.subscribe("/odom", lambda m: None)
    remove = bus.tap(lambda topic, msg: None, cdr=lambda *item: None, cdr_rows=lambda *batch: None)
    assert bus.sole_feeder("/odom") is None  # a plain subscriber, not a feeder
    bus.latch("/joint_states")
    assert bus.sole_feeder("/joint_states") is None


def test_a_listener_answer_follows_subscribers_taps_and_the_bus_it_is_asked_of() -> None:
    """ListenerAnswer keeps has_listeners()' answer while nobody comes or goes, and gives the bus's own answer again as
    soon as a subscriber or a tap comes or goes, at every ask while a tap decides by itself (a bridge), for another
    bus, and after forget()."""
    from racecar_sim.bus import ListenerAnswer

    bus, other = Bus(), Bus()
    asked: list[Bus] = []
    target = [bus]

    def work() -> bool:
        asked.append(target[0])
        return target[0].has_listeners("/scan")

    answer = ListenerAnswer(work)
    assert answer(bus) is False and answer(bus) is False and len(asked) == 1  # kept
    sub = bus.subscribe("/scan", lambda m: None)
    assert answer(bus) is True and answer(bus) is True and len(asked) == 2  # a subscriber came: asked again, once
    sub.unsubscribe()
    assert answer(bus) is False and len(asked) == 3
    remove = bus.tap(lambda topic, msg: None)  # a recorder: every topic
    assert answer(bus) is True and len(asked) == 4
    remove()
    assert answer(bus) is False and len(asked) == 5
    wanted = {"/scan"}
    remove = bus.tap(lambda topic, msg: None, wants=lambda topic: topic in wanted)  # a bridge: may change any time
    assert answer(bus) is True
    wanted.clear()  # nothing on the bus moved, but the bridge's answer did
    assert answer(bus) is False and answer(bus) is False and len(asked) == 8  # asked at every ask meanwhile
    remove()
    assert answer(bus) is False and answer(bus) is False and len(asked) == 9
    target[0] = other
    other.subscribe("/scan", lambda m: None)
    assert answer(other) is True and len(asked) == 10  # another bus: its own answer
    answer.forget()
    assert answer(other) is True and len(asked) == 11
    assert answer(other) is True and len(asked) == 11
