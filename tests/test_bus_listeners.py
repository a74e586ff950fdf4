"""Bus additions for bridges: declared subscriber types (listened) and taps that want only some topics."""

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
