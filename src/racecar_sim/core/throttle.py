"""Rate-limited warnings, as rospy's logwarn_throttle: a bad input stream is named, not repeated 1000 times."""

from __future__ import annotations

import logging
import time


class ThrottledWarning:
    """Warns at most once per `period` wall seconds per key; the next warning counts the ones held back."""

    def __init__(self, log: logging.Logger, period: float = 5.0) -> None:
        self.log, self.period = log, period
        self._last: dict[str, float] = {}
        self._held: dict[str, int] = {}

    def __call__(self, key: str, message: str, *args: object) -> None:
        now = time.monotonic()
        last = self._last.get(key)
        if last is not None and now - last < self.period:
            self._held[key] = self._held.get(key, 0) + 1
            return
        self._last[key] = now
        held = self._held.pop(key, 0)
        if held:
            message += f" ({held} more since the last warning)"
        self.log.warning(message, *args)
