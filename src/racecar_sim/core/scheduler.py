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


@dataclass(order=True)
class _Entry:
    time_ns: int
    seq: int
    task: Task = field(compare=False)


@dataclass(eq=False)
class Task:
    """A scheduled callback; cancel() stops it."""

    name: str
    callback: Callable[[int], None]
    period_ns: Fraction | None = None  # None: one-shot
    start_ns: int = 0
    index: int = 0
    cancelled: bool = False

    def cancel(self) -> None:
        self.cancelled = True


def _ceil(x: Fraction) -> int:
    return -(-x.numerator // x.denominator)


class Scheduler:
    """A periodic task at rate r fires at the k-th multiple of 1/r s (k = 1, 2, ...), rounded up to the
    next physics step when the period is not a whole number of steps; ties run in registration order."""

    def __init__(self, step_ns: int) -> None:
        self.step_ns = step_ns
        self._heap: list[_Entry] = []
        self._seq = itertools.count()

    def _push(self, time_ns: int, task: Task) -> None:
        heapq.heappush(self._heap, _Entry(ceil_to_step(time_ns, self.step_ns), next(self._seq), task))

    def every(self, rate_hz: float, callback: Callable[[int], None], name: str, start_ns: int = 0) -> Task:
        """Call `callback(now_ns)` at start + k/rate for k = 1, 2, ..."""
        if not rate_hz > 0 or not math.isfinite(rate_hz):
            raise ConfigError(f"task {name}: rate must be a positive number, got {rate_hz}")
        if rate_hz * self.step_ns > NS_PER_S:  # it would fire several times per step, or forever at 1 ns
            raise ConfigError(f"task {name}: rate {rate_hz:g} Hz is faster than the physics "
                              f"({NS_PER_S / self.step_ns:g} steps/s)")
        period = Fraction(NS_PER_S) / Fraction(rate_hz).limit_denominator(1_000_000)
        task = Task(name, callback, period, start_ns, index=1)
        self._push(start_ns + _ceil(period), task)
        return task

    def at(self, time_ns: int, callback: Callable[[int], None], name: str) -> Task:
        """Call `callback(now_ns)` once, at the first physics step at or after time_ns."""
        task = Task(name, callback)
        self._push(time_ns, task)
        return task

    def reset(self) -> None:
        """Sim time is back at 0: every periodic task starts over (next fire at its first period) and one-shot
        tasks are dropped (a node that wants a timer after a reset sets it again in its reset hook)."""
        tasks = [entry.task for entry in sorted(self._heap)  # a periodic task has one entry: its next firing
                 if not entry.task.cancelled and entry.task.period_ns is not None]
        self._heap = []
        for task in tasks:
            task.start_ns, task.index = 0, 1
            self._push(_ceil(task.period_ns), task)

    def next_time(self) -> int | None:
        """Sim time of the next live task, or None."""
        while self._heap and self._heap[0].task.cancelled:
            heapq.heappop(self._heap)
        return self._heap[0].time_ns if self._heap else None

    def run_due(self, now_ns: int) -> None:
        """Run every task due at or before now_ns (including ones scheduled by those tasks)."""
        while self._heap and self._heap[0].time_ns <= now_ns:
            entry = heapq.heappop(self._heap)
            task = entry.task
            if task.cancelled:
                continue
            if task.period_ns is not None:
                task.index += 1
                self._push(task.start_ns + _ceil(task.period_ns * task.index), task)
            task.callback(now_ns)
