"""An answer about who listens on a bus, kept while the bus's listeners stay the same."""

from __future__ import annotations

from collections.abc import Callable
from typing import Generic, Protocol, TypeVar

T = TypeVar("T")


class _Listened(Protocol):
    def listeners_epoch(self) -> int | None: ...


class ListenerAnswer(Generic[T]):
    """`work()`'s answer (has_listeners, cdr_only, sole_taker, ... of some topics), worked out again only when the
    bus asked about is another one (a stopped controller's muted outlet) or its listeners_epoch() moved (a
    subscriber or a tap came or went), and at every ask while that is None (a bridge's taps decide by themselves).
    A publisher asks it at every tick; the bus's answers cost a walk over its taps."""

    __slots__ = ("_answer", "_bus", "_epoch", "_work")

    def __init__(self, work: Callable[[], T]) -> None:
        self._work = work
        self._bus: object = None
        self._epoch: int | None = None
        self._answer: T

    def __call__(self, bus: _Listened) -> T:
        epoch = bus.listeners_epoch()
        if epoch is None or epoch != self._epoch or bus is not self._bus:
            self._answer = self._work()
            self._bus, self._epoch = bus, epoch
        return self._answer

    def forget(self) -> None:
        """Work the answer out again at the next ask (something it depends on besides the listeners changed)."""
        self._bus = None
