"""Fire periodic and one-shot tasks at exact sim times, aligned to the physics step."""

from __future__ import annotations

import heapq
import itertools
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from fractions import Fraction

from racecar_sim.core.errors import ConfigError
from racecar_sim.core.time import NS_PER_S, ceil_to_step


@dataclass(eq=False)
class Task:
    """A scheduled callback; cancel() stops it."""

    name: str
    callback: Callable[[int], None]
    period_ns: Fraction | None = None  # None: one-shot
    start_ns: int = 0
    index: int = 0
    cancelled: bool = False
    # does a firing whose messages nobody would receive, ahead of the physics (see Scheduler.every)
    unheard: Callable[[int], bool] | None = None
    # the period as a whole fraction of ns, for the k-th firing in integer arithmetic (a Fraction costs microseconds)
    _numerator: int = field(default=0, init=False, repr=False)
    _denominator: int = field(default=1, init=False, repr=False)
    # where the period is a whole number of physics steps and the start is a step: the period in ns, and each firing
    # is the last one's time plus it (the formula's own result, without its arithmetic); else 0
    _stride: int = field(default=0, init=False, repr=False)

    def __post_init__(self) -> None:
        if self.period_ns is not None:
            self._numerator, self._denominator = self.period_ns.numerator, self.period_ns.denominator

    def cancel(self) -> None:
        self.cancelled = True


class Timeout:
    """A one-shot timer that is restarted far more often than it fires (a mux input's timeout, restarted by every
    message): restart(t) moves it to the first physics step at or after t without a new heap entry per call. It
    fires once, at the last time set, in the very order a fresh one-shot set at that moment would (it takes its tie
    rank then), so it behaves as cancelling the old one-shot and setting a new one; stop() unsets it, cancel()
    ends it for good. The heap keeps one entry for it; one that comes up before the time set is moved on lazily."""

    __slots__ = ("name", "callback", "cancelled", "_scheduler", "_due", "_entry", "__weakref__")
    period_ns = unheard = None  # one-shot, as far as run_due and reset are concerned

    def __init__(self, scheduler: Scheduler, callback: Callable[[int], None], name: str) -> None:
        self.name, self.callback, self._scheduler = name, callback, scheduler
        self.cancelled = False
        self._due: tuple[int, int] | None = None  # (time_ns, tie rank) it fires at; None: not set
        self._entry: tuple[int, int] | None = None  # (time_ns, tie rank) of its live heap entry; None: none

    @property
    def due_ns(self) -> int | None:
        """The sim time it fires at (a physics step), or None when it is not set."""
        return None if self._due is None else self._due[0]

    def restart(self, time_ns: int) -> None:
        """Fire at the first physics step at or after `time_ns` instead of at the time set before (if any)."""
        if self.cancelled:
            return
        scheduler = self._scheduler
        step = scheduler.step_ns
        due = self._due = (-(-time_ns // step) * step, next(scheduler._seq))
        entry = self._entry
        if entry is None or entry[0] > due[0]:  # else the queued entry comes up first and is moved on then
            self._entry = due
            heapq.heappush(scheduler._heap, (due[0], due[1], self))

    def stop(self) -> None:
        """Unset: it does not fire until restarted."""
        self._due = None

    def cancel(self) -> None:
        """Never fire again."""
        self.cancelled, self._due = True, None

    def _take(self, time_ns: int, rank: int) -> bool:
        """Its heap entry (time_ns, rank) came up: whether to fire now (else the entry is dropped or moved on)."""
        entry = self._entry
        if entry is None or entry[0] != time_ns or entry[1] != rank:
            return False  # an entry left behind when a restart moved the time earlier
        due = self._due
        if due is None:
            self._entry = None
            return False
        if due[0] == time_ns and due[1] == rank:
            self._entry = self._due = None
            return True
        self._entry = due  # restarted since: queue it at the time (and with the tie rank) set last
        heapq.heappush(self._scheduler._heap, (due[0], due[1], self))
        return False


def _ceil(x: Fraction) -> int:
    return -(-x.numerator // x.denominator)


class Scheduler:
    """A periodic task at rate r fires at the k-th multiple of 1/r s (k = 1, 2, ...), rounded up to the
    next physics step when the period is not a whole number of steps; ties run in registration order."""

    def __init__(self, step_ns: int) -> None:
        self.step_ns = step_ns
        # (time_ns, seq, task): tuples compare in C; seq is unique, so tasks are never compared
        self._heap: list[tuple[int, int, Task | Timeout]] = []
        self._seq = itertools.count()

    def _push(self, time_ns: int, task: Task) -> None:
        heapq.heappush(self._heap, (ceil_to_step(time_ns, self.step_ns), next(self._seq), task))

    def every(
        self,
        rate_hz: float,
        callback: Callable[[int], None],
        name: str,
        start_ns: int = 0,
        unheard: Callable[[int], bool] | None = None,
    ) -> Task:
        """Call `callback(now_ns)` at start + k/rate for k = 1, 2, ...

        `unheard(now_ns)`, for a task that only publishes: when nobody would receive what it publishes now, do what
        the callback would then do (count the message on the bus, or nothing) and return True; else return False.
        next_time() asks it at the task's time, in the task's order, without the physics stopping there (a 100 Hz
        /clock that nobody reads costs no stop); the callback runs, at a stop, only after a False."""
        if not rate_hz > 0 or not math.isfinite(rate_hz):
            raise ConfigError(f"task {name}: rate must be a positive number, got {rate_hz}")
        if rate_hz * self.step_ns > NS_PER_S:  # it would fire several times per step, or forever at 1 ns
            raise ConfigError(
                f"task {name}: rate {rate_hz:g} Hz is faster than the physics ({NS_PER_S / self.step_ns:g} steps/s)"
            )
        period = Fraction(NS_PER_S) / Fraction(rate_hz).limit_denominator(1_000_000)
        task = Task(name, callback, period, start_ns, index=1, unheard=unheard)
        if period.denominator == 1 and period.numerator % self.step_ns == 0 and start_ns % self.step_ns == 0:
            task._stride = period.numerator  # a reset starts it at 0, a step too
        self._push(start_ns + _ceil(period), task)
        return task

    def at(self, time_ns: int, callback: Callable[[int], None], name: str) -> Task:
        """Call `callback(now_ns)` once, at the first physics step at or after time_ns."""
        task = Task(name, callback)
        self._push(time_ns, task)
        return task

    def timeout(self, callback: Callable[[int], None], name: str) -> Timeout:
        """A Timeout (not set yet) that calls `callback(now_ns)` when it runs out."""
        return Timeout(self, callback, name)

    def reset(self) -> None:
        """Sim time is back at 0: every periodic task starts over (next fire at its first period) and one-shot
        tasks are dropped (a node that wants a timer after a reset sets it again in its reset hook)."""
        tasks = [
            (task, task.period_ns)
            for _, _, task in sorted(self._heap)  # a periodic task has one entry: its next firing
            if not task.cancelled and task.period_ns is not None
        ]
        for _, _, task in self._heap:
            if type(task) is Timeout:
                task._entry = task._due = None
        self._heap = []
        for task, period_ns in tasks:
            task.start_ns, task.index = 0, 1
            self._push(_ceil(period_ns), task)

    def next_time(self, until_ns: int | None = None) -> int | None:
        """Sim time of the next live task, or None.

        With `until_ns`: the tasks due first (at or before it) whose firing nobody would hear (see every()) are done
        here, each at its own time and in its order (they need nothing of the physics, and no other task comes
        before them), and the time returned is that of the first task that needs the physics there."""
        heap = self._heap
        if until_ns is None:
            until_ns = -1  # no task is done here
        while heap:
            time_ns, rank, task = heap[0]
            if task.cancelled:
                heapq.heappop(heap)
            elif type(task) is Timeout:
                if task._due == (time_ns, rank):
                    return time_ns
                heapq.heappop(heap)  # stopped, or restarted since it was queued
                task._take(time_ns, rank)
            elif time_ns <= until_ns and task.unheard is not None and task.unheard(time_ns):
                task.index += 1  # done: a periodic task (only every() gives unheard) goes on to its next firing
                if task._stride:
                    heapq.heapreplace(heap, (time_ns + task._stride, next(self._seq), task))
                    continue
                fire = task.start_ns - (-(task._numerator * task.index) // task._denominator)
                step = self.step_ns
                heapq.heapreplace(heap, (-(-fire // step) * step, next(self._seq), task))
            else:
                return time_ns
        return None

    def run_due(self, now_ns: int) -> None:
        """Run every task due at or before now_ns (including ones scheduled by those tasks)."""
        heap, step, pop, replace, seq = self._heap, self.step_ns, heapq.heappop, heapq.heapreplace, self._seq
        while heap:
            time_ns, rank, task = heap[0]
            if time_ns > now_ns:
                break
            if task.period_ns is not None and not task.cancelled:
                task.index += 1  # its next firing takes its place in the heap (one sift instead of a pop and a push)
                if task._stride:
                    replace(heap, (time_ns + task._stride, next(seq), task))
                else:
                    fire = task.start_ns - (-(task._numerator * task.index) // task._denominator)
                    replace(heap, (-(-fire // step) * step, next(seq), task))
                task.callback(now_ns)
                continue
            pop(heap)
            if task.cancelled or (type(task) is Timeout and not task._take(time_ns, rank)):
                continue
            task.callback(now_ns)
