"""The scheduler's firing times and the bus's delivery order, against their definitions written out independently."""

from __future__ import annotations

import math
from fractions import Fraction

import pytest

from racecar_sim.bus import Bus
from racecar_sim.msgs import String
from racecar_sim.runtime.scheduler import Scheduler

STEP_NS = 1_000_000  # 1 ms physics step


@pytest.mark.parametrize("rate", [100.0, 50.0, 40.0, 30.0, 7.0, 6.0, 3.3, 0.7])
@pytest.mark.parametrize("start_ns", [2_500_000, 0, 2_000_000])  # between two steps (a car spawned at run time), on one
def test_periodic_tasks_fire_at_the_kth_period_rounded_up_to_a_step(rate, start_ns):
    scheduler = Scheduler(STEP_NS)
    fired: list[int] = []
    scheduler.every(rate, fired.append, "task", start_ns=start_ns)
    for now in range(0, 4_000_000_000, STEP_NS):
        scheduler.run_due(now)
    period = Fraction(10**9) / Fraction(rate).limit_denominator(1_000_000)
    expected = [math.ceil((start_ns + math.ceil(period * k)) / STEP_NS) * STEP_NS for k in range(1, len(fired) + 1)]
    assert fired == expected and fired[-1] > 4_000_000_000 - 2 * 10**9 / rate
    fired.clear()
    scheduler.reset()  # sim time back at 0: the task starts over from 0
    for now in range(0, 4_000_000_000, STEP_NS):
        scheduler.run_due(now)
    assert fired == [math.ceil(math.ceil(period * k) / STEP_NS) * STEP_NS for k in range(1, len(fired) + 1)]
    assert fired[-1] > 4_000_000_000 - 2 * 10**9 / rate


def test_ties_run_in_registration_order_and_cancelled_tasks_never_run():
    scheduler = Scheduler(STEP_NS)
    order: list[str] = []
    scheduler.every(100.0, lambda t: order.append("a"), "a")
    scheduler.at(10_000_000, lambda t: order.append("once"), "once")
    scheduler.every(100.0, lambda t: order.append("b"), "b")
    scheduler.at(10_000_000, lambda t: order.append("never"), "never").cancel()
    scheduler.run_due(10_000_000)
    assert order == ["a", "once", "b"]
    order.clear()
    scheduler.reset()
    assert scheduler.next_time() == 10_000_000
    scheduler.run_due(20_000_000)
    assert order == ["a", "b", "a", "b"]


def test_a_message_goes_to_those_subscribed_when_it_was_published():
    bus = Bus()
    got: list[str] = []
    late = []

    def first(msg: String) -> None:
        got.append("first " + msg.data)
        second_sub.unsubscribe()  # still gets this message: delivery started before
        late.append(bus.subscribe("/t", lambda m: got.append("late " + m.data)))  # gets only the next ones

    bus.subscribe("/t", first)
    second_sub = bus.subscribe("/t", lambda m: got.append("second " + m.data))
    bus.publish("/t", String("1"))
    assert got == ["first 1", "second 1"]
    got.clear()
    bus.publish("/t", String("2"))
    assert got == ["first 2", "late 2"]
    assert bus.has_listeners("/t") and not bus.has_listeners("/nobody")
    for sub in late:
        sub.unsubscribe()


def test_a_restarted_timeout_fires_as_a_fresh_one_shot_would():
    """A Timeout restarted at random moments fires when, and in the tie order in which, cancelling the previous
    one-shot and setting a new one (the definition) fires, among periodic tasks at the same instants."""
    import random

    rng = random.Random(7)
    restarts = sorted(rng.sample(range(0, 500), 25))  # steps at which a "message" restarts the timer
    timeouts = [rng.choice([10, 20, 25, 30]) for _ in restarts]  # ms: the timer's run-out time, a tie with a tick

    def run(lazy: bool) -> list[tuple[int, str]]:
        scheduler = Scheduler(STEP_NS)
        fired: list[tuple[int, str]] = []
        scheduler.every(100.0, lambda t: fired.append((t, "tick")), "tick")
        timeout = scheduler.timeout(lambda t: fired.append((t, "timeout")), "timeout")
        one_shot = None
        plan = dict(zip(restarts, timeouts))
        for step in range(0, 600):
            now = step * STEP_NS
            if step in plan:
                if lazy:
                    timeout.restart(now + plan[step] * 1_000_000)
                else:
                    if one_shot is not None:
                        one_shot.cancel()
                    one_shot = scheduler.at(
                        now + plan[step] * 1_000_000, lambda t: fired.append((t, "timeout")), "timeout"
                    )
            scheduler.next_time()
            scheduler.run_due(now)
        return fired

    expected = run(lazy=False)
    assert run(lazy=True) == expected and sum(name == "timeout" for _, name in expected) > 3


def test_a_timeout_stopped_or_cancelled_does_not_fire_and_next_time_skips_it():
    scheduler = Scheduler(STEP_NS)
    fired: list[int] = []
    timeout = scheduler.timeout(fired.append, "timeout")
    timeout.restart(5_000_000)
    timeout.restart(3_000_000)  # earlier than the queued entry: fires at 3 ms, once
    scheduler.every(100.0, lambda t: None, "tick")
    assert scheduler.next_time() == 3_000_000 and timeout.due_ns == 3_000_000
    scheduler.run_due(3_000_000)
    scheduler.run_due(9_000_000)
    assert fired == [3_000_000] and timeout.due_ns is None
    timeout.restart(12_000_000)
    timeout.stop()
    assert scheduler.next_time() == 10_000_000
    scheduler.run_due(20_000_000)
    timeout.restart(25_000_000)
    timeout.cancel()
    timeout.restart(26_000_000)  # cancelled for good
    scheduler.run_due(40_000_000)
    assert fired == [3_000_000]


def test_an_unheard_task_is_done_ahead_of_the_physics_and_in_its_order():
    scheduler = Scheduler(STEP_NS)
    calls: list[tuple[str, int]] = []
    heard = {"clock": False}

    def unheard(now_ns: int) -> bool:
        calls.append(("unheard", now_ns))
        return not heard["clock"]

    scheduler.every(100.0, lambda t: calls.append(("clock", t)), "clock", unheard=unheard)
    scheduler.every(40.0, lambda t: calls.append(("scan", t)), "scan")
    # nobody hears the clock: its 10 and 20 ms firings are done here, the physics need stop only for the scan
    assert scheduler.next_time(until_ns=100_000_000) == 25_000_000
    assert calls == [("unheard", 10_000_000), ("unheard", 20_000_000)]
    scheduler.run_due(25_000_000)
    heard["clock"] = True  # a subscriber came (in the scan's callback): the next clock tick needs a stop
    assert scheduler.next_time(until_ns=100_000_000) == 30_000_000
    scheduler.run_due(30_000_000)
    assert calls[2:] == [("scan", 25_000_000), ("unheard", 30_000_000), ("clock", 30_000_000)]
    assert scheduler.next_time() == 40_000_000  # without until_ns: every task stops the physics, as before
    assert scheduler.next_time(until_ns=35_000_000) == 40_000_000  # nothing done past until_ns


def test_a_tallied_message_counts_as_published_and_feeds_what_its_subscribers_make_of_it():
    bus = Bus()
    fed: list[String] = []
    bus.subscribe("/joints", lambda msg: bus.publish("/tf", msg), feeds={"/tf": String})
    assert not bus.has_listeners("/joints")  # it feeds /tf, which nobody hears
    bus.tally("/joints", String)
    assert bus.count("/joints") == 1 and bus.count("/tf") == 1 and bus.topics()["/tf"] is String
    sub = bus.subscribe("/tf", fed.append)
    assert bus.has_listeners("/joints")
    bus.publish("/joints", String("a"))
    assert [m.data for m in fed] == ["a"] and bus.count("/tf") == 2
    sub.unsubscribe()
    assert not bus.has_listeners("/joints")
    bus.latch("/latched")
    with pytest.raises(ValueError):
        bus.tally("/latched", String)
    with pytest.raises(TypeError):
        bus.tally("/tf", int)
