"""Laps: each car's crossings of the world's start line (worlds/start_line.py), counted and timed.

A car's first forward crossing starts its first lap (a standing start behind the line); each next one, after it has
driven at least MIN_LAP_SHARE of the course's length (or MIN_LAP_DISTANCE without a centerline) since the last,
completes a lap. The crossing time is interpolated between two samples of the car's pose, taken at LAP_RATE on the
odometry's ticks. Each lap goes out on /racecar_sim/lap (std_msgs/String "<car> <laps> <last lap s> <best lap s>",
as /racecar_sim/collisions names cars) and is kept in `records` for the run's summary.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

from racecar_sim.bus import BusPort
from racecar_sim.core.time import NS_PER_S
from racecar_sim.msgs import String
from racecar_sim.nodes import Cancellable, NodeBase, Timers
from racecar_sim.worlds.start_line import StartLine

LAP = "/racecar_sim/lap"
LAP_RATE = 20.0  # Hz of sim time: the odometry's (no extra stop of the physics)
MIN_LAP_SHARE = 0.5  # of the centerline's length, driven between two crossings that make a lap
MIN_LAP_DISTANCE = 5.0  # m, the same without a centerline


@dataclass
class LapRecord:
    """One car's laps: when its first lap started (None: it has not crossed yet) and each lap's time, in ns."""

    car: str
    started_ns: int | None = None
    times_ns: list[int] = field(default_factory=list)

    @property
    def count(self) -> int:
        """Laps completed."""
        return len(self.times_ns)

    @property
    def times(self) -> list[float]:
        """Each lap's time in s."""
        return [t / NS_PER_S for t in self.times_ns]

    @property
    def best(self) -> float | None:
        """The fastest lap in s, or None."""
        return min(self.times_ns) / NS_PER_S if self.times_ns else None


@dataclass
class _Tracked:
    record: LapRecord
    pose: Callable[[], tuple[float, float]]
    last: tuple[float, float] | None = None
    last_ns: int = 0
    driven: float = 0.0
    crossed_ns: int | None = None


class Laps(NodeBase):
    """The lap counter of the world: `watch(cars)` with (name, pose getter) pairs; records by car name."""

    def __init__(self, bus: BusPort, timers: Timers, line: StartLine, course_length: float | None) -> None:
        self.bus, self.line = bus, line
        self.min_lap = MIN_LAP_SHARE * course_length if course_length else MIN_LAP_DISTANCE
        self.records: dict[str, LapRecord] = {}
        self._cars: list[_Tracked] = []
        self._task: Cancellable = timers.every(LAP_RATE, self._tick, "laps")

    def watch(self, cars: Sequence[tuple[str, Callable[[], tuple[float, float]]]]) -> None:
        """Track these cars (a car kept from before keeps its laps; a new one starts with none)."""
        kept = {t.record.car: t for t in self._cars}
        self._cars = []
        for name, pose in cars:
            tracked = kept.get(name) or _Tracked(self.records.setdefault(name, LapRecord(name)), pose)
            tracked.pose = pose
            self._cars.append(tracked)

    def _tick(self, now_ns: int) -> None:
        for car in self._cars:
            here = car.pose()
            last = car.last
            car.last, car.last_ns, before_ns = here, now_ns, car.last_ns
            if last is None:
                continue
            car.driven += math.hypot(here[0] - last[0], here[1] - last[1])
            t = self.line.crossing(last, here)
            if t is None:
                continue
            when = before_ns + round(t * (now_ns - before_ns))
            record = car.record
            if record.started_ns is None:
                record.started_ns, car.crossed_ns, car.driven = when, when, 0.0
            elif car.driven >= self.min_lap and car.crossed_ns is not None:
                record.times_ns.append(when - car.crossed_ns)
                car.crossed_ns, car.driven = when, 0.0
                best = record.best or 0.0
                self.bus.publish(LAP, String(f"{record.car} {record.count} {record.times[-1]:.3f} {best:.3f}"))

    def reset(self, seed: int) -> None:
        for car in self._cars:
            car.record.started_ns, car.record.times_ns = None, []
            car.last, car.last_ns, car.driven, car.crossed_ns = None, 0, 0.0, None

    def close(self) -> None:
        self._task.cancel()
