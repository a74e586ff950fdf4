"""servo_commands' law, written once: drive commands (speed, steering_angle) -> wheel rates and hinge angles.

Called by the servo_commands node (control/servo.py) for one command, with floats, and by the batch of worlds
(envs/batch_command.py) for one command per world, with arrays: the same formulas on either, so that both turn a
command into the same numbers, bit for bit.

Modes (a driving profile's `servo`, profiles.yaml):
  ackermann  the seed: each hinge at the angle of formula (2), atan(L / (R - y_hinge)), clamped to its joint limits
             (the turn is made no tighter than the tightest hinge allows); each wheel at the rate its tyre's ground
             point moves along the wheel's heading, so that no wheel slips, `speed` being the ground speed of
             base_link (the rear-axle centre).
  parallel   the original servo_commands.py: every wheel at speed * rate_per_speed rad/s, both hinges at the
             steering angle.

Top speed (both modes): where a wheel's rate would pass its joint's velocity limit, every wheel rate is scaled by
the same factor, so that the fastest wheel runs at its limit and the others keep their ratios to it: the car drives
the commanded path at the highest speed its wheels allow, as if the command's speed had been lowered. Clipping the
one wheel instead (what ros_control's clamp alone would do) makes the wheels fight and the car slide out of the
bend. A command every wheel can follow is left exactly as it was.

The transcendental functions are libm's (Python's math; over arrays applied element by element): numpy's own tan,
arctan2, cos and sin differ from libm's in the last bit for some inputs, and a wheel rate one ulp off would make a
batch world drift from the single car it mirrors. A float command is computed with Python's operators (a numpy call
costs a microsecond, and the node runs at every command), an array of them with numpy's.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

MODES = ("ackermann", "parallel")


def _libm(function: Callable[..., float], arity: int = 1) -> Callable[..., np.ndarray]:
    """`function` (math's) element by element over arrays, as float64."""
    ufunc = np.frompyfunc(function, arity, 1)
    return lambda *args: np.asarray(ufunc(*args), dtype=np.float64)


@dataclass(frozen=True)
class _Elementwise:
    """The operations the law needs beyond + - * /, for floats or for arrays."""

    tan: Callable[[Any], Any]
    atan2: Callable[[Any, Any], Any]
    cos: Callable[[Any], Any]
    sin: Callable[[Any], Any]
    abs: Callable[[Any], Any]
    copysign: Callable[[Any, Any], Any]
    select: Callable[[Any, Any, Any], Any]  # (condition, where true, where false)
    minimum: Callable[[Any, Any], Any]
    maximum: Callable[[Any, Any], Any]


FLOATS = _Elementwise(
    math.tan,
    math.atan2,
    math.cos,
    math.sin,
    abs,
    math.copysign,
    lambda condition, yes, no: yes if condition else no,
    min,
    max,
)
ARRAYS = _Elementwise(
    _libm(math.tan),
    _libm(math.atan2, 2),
    _libm(math.cos),
    _libm(math.sin),
    np.abs,
    np.copysign,
    np.where,
    np.minimum,
    np.maximum,
)


@dataclass(frozen=True)
class ServoWheel:
    """One wheel as the law sees it: its tyre centre in base_link (x, y) at zero steer, for a steered wheel the
    point (x, y) where its steering axis meets the ground and the hinge joint's limits (None: a continuous hinge),
    and the wheel joint's velocity limit in rad/s (None: unlimited)."""

    centre: tuple[float, float]
    hinge: tuple[float, float] | None = None
    hinge_limits: tuple[float, float] | None = None
    rate_limit: float | None = None


class ServoLaw:
    """The law of one car: its wheels (in the description's order), wheelbase, wheel radius and mode.

    `outputs` names the values the law returns, in the order servo_commands publishes them: (wheel index, True for
    its hinge angle / False for its wheel rate). ackermann: each wheel's hinge (where it has one) then its rate;
    parallel: every wheel's rate, then every hinge. `max_curvature` (1/m) is the tightest turn the hinge limits
    allow (inf where no hinge has limits).
    """

    def __init__(
        self,
        mode: str,
        wheels: Sequence[ServoWheel],
        wheelbase: float,
        wheel_radius: float,
        rate_per_speed: float,
        steer_range: tuple[float, float] | None = None,
        speed_range: tuple[float, float] | None = None,
    ) -> None:
        if mode not in MODES:
            raise ValueError(f"servo mode '{mode}' is not ackermann or parallel")
        self.mode, self.wheels = mode, tuple(wheels)
        self.wheelbase, self.wheel_radius, self.rate_per_speed = wheelbase, wheel_radius, rate_per_speed
        # a vehicle set's command limits (F1TENTH's s_min..s_max, v_min..v_max); None: as the seed, none
        self.steer_range, self.speed_range = steer_range, speed_range
        steered = [i for i, w in enumerate(self.wheels) if w.hinge is not None]
        if mode == "ackermann":
            outputs = [row for i in range(len(self.wheels)) for row in [(i, True)] * (i in steered) + [(i, False)]]
        else:
            outputs = [(i, False) for i in range(len(self.wheels))] + [(i, True) for i in steered]
        self.outputs: tuple[tuple[int, bool], ...] = tuple(outputs)
        self.max_curvature = self._max_curvature()
        # the last command() and its result: a driver repeating its command (a constant one, a car at rest) gets the
        # same floats again without the law's ~40 operations; the key tells 0.0 from -0.0 (copysign sees the sign)
        self._last_key: tuple[float, float, float, float] | None = None
        self._last: tuple[list[float], bool] = ([], False)

    def _max_curvature(self) -> float:
        """The tightest turn whose inner hinge angle stays within its joint limit (formula (2) solved for 1/R)."""
        limit = math.inf
        for w in self.wheels:
            if w.hinge is not None and w.hinge_limits is not None:
                for bound in w.hinge_limits:
                    t = abs(math.tan(bound))
                    limit = min(limit, t / (w.hinge[0] + abs(w.hinge[1]) * t))
        return limit

    def command(self, speed: float, steer: float) -> tuple[list[float], bool]:
        """(values, clamped) for one command, speed (m/s) and steering_angle (rad): a value per output (rad for a
        hinge, rad/s for a wheel); clamped: the steering angle asked for a hinge past its limit, and the turn was
        made as tight as the limits allow."""
        speed, steer = float(speed), float(steer)
        key = (speed, steer, math.copysign(1.0, speed), math.copysign(1.0, steer))
        if key != self._last_key:  # a NaN never equals itself: such a command is worked out every time
            self._last = self._law(speed, steer, FLOATS)
            self._last_key = key
        values, clamped = self._last
        return list(values), clamped

    def commands(self, speed: np.ndarray, steer: np.ndarray) -> tuple[list[np.ndarray], np.ndarray]:
        """command() for arrays of N commands: a value array (N,) per output, and clamped (N,)."""
        return self._law(np.asarray(speed, np.float64), np.asarray(steer, np.float64), ARRAYS)

    def _law(self, speed: Any, steer: Any, op: _Elementwise) -> tuple[list[Any], Any]:
        """The law, with `op`'s functions for floats or arrays (the arithmetic is the same on both)."""
        if self.steer_range is not None:
            steer = op.minimum(op.maximum(steer, self.steer_range[0]), self.steer_range[1])
        if self.speed_range is not None:
            speed = op.minimum(op.maximum(speed, self.speed_range[0]), self.speed_range[1])
        if self.mode == "parallel":
            rate = speed * self.rate_per_speed
            never = op.abs(speed) < 0.0  # False (per command): the parallel mode takes any angle
            rates = self._top_speed([rate] * len(self.wheels), op)
            return [steer if hinge else rates[i] for i, hinge in self.outputs], never
        kappa = op.tan(steer) / self.wheelbase  # path curvature of base_link, 1/R
        clamped = op.abs(kappa) > self.max_curvature
        kappa = op.select(clamped, op.copysign(self.max_curvature, kappa), kappa)
        yaw_rate = speed * kappa
        out = []
        for w in self.wheels:
            (cx, cy), c, s = w.centre, 1.0, 0.0  # c, s: cos and sin of the wheel's heading (exactly these at 0)
            if w.hinge is not None:
                hx, hy = w.hinge
                # atan(L / (R - y_hinge)), written with curvature so that straight ahead needs no special case
                heading = op.atan2(hx * kappa, 1.0 - kappa * hy)
                heading = op.select(heading > math.pi / 2, heading - math.pi, heading)
                heading = op.select(heading < -math.pi / 2, heading + math.pi, heading)
                if w.hinge_limits is not None:
                    heading = op.minimum(op.maximum(heading, w.hinge_limits[0]), w.hinge_limits[1])
                c, s = op.cos(heading), op.sin(heading)
                ox, oy = cx - hx, cy - hy
                cx, cy = hx + (c * ox - s * oy), hy + (s * ox + c * oy)  # the tyre centre, turned about the hinge
                out.append(heading)
            # velocity of the tyre's ground point, projected on the wheel's heading
            vx, vy = speed - yaw_rate * cy, yaw_rate * cx
            out.append((vx * c + vy * s) / self.wheel_radius)
        rates = self._top_speed([out[k] for k, (_, hinge) in enumerate(self.outputs) if not hinge], op)
        wheel_rates = iter(rates)
        return [value if hinge else next(wheel_rates) for value, (_, hinge) in zip(out, self.outputs)], clamped

    def _top_speed(self, rates: list[Any], op: _Elementwise) -> list[Any]:
        """The wheel rates (one per wheel, in order) scaled together so that none passes its velocity limit; rates
        within every limit are returned as they are (not multiplied by 1.0, which is the same, but by no operation)."""
        limited = [w.rate_limit is not None for w in self.wheels]
        if not any(limited):
            return rates
        scale: Any = 1.0
        for rate, w in zip(rates, self.wheels):
            if w.rate_limit is not None:
                magnitude = op.abs(rate)
                over = magnitude > w.rate_limit
                scale = op.minimum(scale, op.select(over, w.rate_limit / op.select(over, magnitude, 1.0), 1.0))
        over_any = scale < 1.0
        return [op.select(over_any, rate * scale, rate) for rate in rates]
