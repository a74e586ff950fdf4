"""Rate-limited warnings, as rospy's logwarn_throttle (on sim time): a bad input stream is named, not repeated."""

from __future__ import annotations

import logging
import math
import numbers
from collections.abc import Callable

from racecar_sim.core.time import NS_PER_S


def is_finite_number(value: object) -> bool:
    """A real, finite number: Python's or numpy's (np.float32 from a policy is fine), not a bool."""
    return isinstance(value, numbers.Real) and not isinstance(value, bool) and math.isfinite(value)


class ThrottledWarning:
    """Warns at most once per `period` seconds of sim time per key; the next warning counts the ones held back."""

    def __init__(self, log: logging.Logger, now: Callable[[], int], period: float = 5.0) -> None:
        self.log, self.now, self.period_ns = log, now, int(period * NS_PER_S)
        self._last: dict[str, int] = {}
        self._held: dict[str, int] = {}

    def __call__(self, key: str, message: str, *args: object) -> None:
        now = self.now()
        last = self._last.get(key)
        if last is not None and now - last < self.period_ns:
            self._held[key] = self._held.get(key, 0) + 1
            return
        self._last[key] = now
        held = self._held.pop(key, 0)
        if held:
            message += f" ({held} more since the last warning)"
        self.log.warning(message, *args)
