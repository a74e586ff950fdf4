"""Sim time is an integer number of nanoseconds; these helpers convert at the edges."""

from __future__ import annotations

NS_PER_S = 1_000_000_000


def to_ns(seconds: float) -> int:
    """Seconds (float) to integer nanoseconds, rounded to the nearest ns."""
    return int(round(seconds * NS_PER_S))


def to_sec(ns: int) -> float:
    """Integer nanoseconds to seconds."""
    return ns / NS_PER_S


def ceil_to_step(t_ns: int, step_ns: int) -> int:
    """The first multiple of step_ns at or after t_ns."""
    return -(-t_ns // step_ns) * step_ns
