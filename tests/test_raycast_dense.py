"""A map's dense cells are cast by raycast.dense, which drops walls and runs of walls hidden behind nearer hits: its
ranges and refusals must be those of level.cast_level on the lean table, which visits every wall, to the last bit, in
dense clutter, from any pose, for any fan."""

from __future__ import annotations

import math

import numpy as np
import pytest

from racecar_sim.sensors.raycast import dense, kernels
from racecar_sim.sensors.raycast.fan import MAX_TILT_COS, Fan
from racecar_sim.sensors.raycast.grid import Cell
from racecar_sim.sensors.raycast.level import cast_level
from racecar_sim.sensors.raycast.scene import boxes_footprints, empty_circles

FANS = {
    "hokuyo": Fan(-0.75 * math.pi, 1.5 * math.pi / 1080, 1081, 0.1, 10.0),  # the racecar's UST-10LX
    "full-turn": Fan(-math.pi, 2 * math.pi / 720, 720, 0.05, 12.0),
    "narrow": Fan(0.3, 0.01, 100, 0.2, 6.0),
    "one-beam": Fan(1.0, 0.0, 1, 0.1, 8.0),
}


def _rotation(yaw: float, tilt: float, tilt_axis: float) -> np.ndarray:
    c, s = math.cos(yaw), math.sin(yaw)
    turn = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    axis = np.array([math.cos(tilt_axis), math.sin(tilt_axis), 0.0])
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    tip = np.eye(3) + math.sin(tilt) * k + (1 - math.cos(tilt)) * k @ k
    return tip @ turn


def _two_sided(rng: np.random.Generator, n: int, zlo: float, zhi: float) -> np.ndarray:
    """n thin walls (scene.py segment columns, two-sided) of random length and direction."""
    a = rng.uniform(-8, 8, (n, 2))
    b = a + rng.uniform(-3, 3, (n, 2))
    mid, half = 0.5 * (a + b), 0.5 * np.linalg.norm(b - a, axis=1)
    one = np.ones(n)
    return np.array(
        [
            a[:, 0],
            a[:, 1],
            b[:, 0],
            b[:, 1],
            zlo * one,
            zhi * one,
            mid[:, 0],
            mid[:, 1],
            half,
            mid[:, 0],
            mid[:, 1],
            half,
            0 * one,
        ]
    )


def _clutter(rng: np.random.Generator, boxes: int, partial: bool) -> np.ndarray:
    """A segment table of a dense scene: map-like cells and runs of boxes (some askew), two-sided walls, and if
    `partial` some low boxes a tilted scan may pass over."""
    pos = np.column_stack([rng.uniform(-9, 9, (boxes, 2)), np.full(boxes, 1.0)])
    half = np.column_stack([rng.choice([0.025, 0.05, 0.3, 2.0], (boxes, 2)), np.full(boxes, 1.0)])
    yaws = np.where(rng.random(boxes) < 0.3, rng.uniform(-math.pi, math.pi, boxes), 0.0)
    rotations = np.array([_rotation(yaw, 0.0, 0.0) for yaw in yaws])
    if partial:
        low = rng.random(boxes) < 0.2
        pos[low, 2], half[low, 2] = 0.15, 0.15
    segments = np.concatenate([boxes_footprints(pos, rotations, half).segments, _two_sided(rng, 20, 0.0, 2.0)], axis=1)
    order = rng.integers(3)
    if order == 0:  # as a grid cell lists them: by tiles (runs, tested as one), near to far from its middle
        return Cell(segments, empty_circles(), empty_circles(), FANS["hokuyo"], tuple(rng.uniform(-3, 3, 2))).segments
    if order == 1:  # near to far, tiles interleaved (runs of one or a few walls)
        return segments[:, np.argsort(np.hypot(segments[6], segments[7]), kind="stable")]
    return segments[:, rng.permutation(segments.shape[1])]


def _bits(ranges: np.ndarray) -> np.ndarray:
    return ranges.view(np.uint64)


def _tables(segments: np.ndarray, fan: Fan, centre: tuple[float, float]) -> tuple[np.ndarray, np.ndarray]:
    """The lean table of the walls, and the dense one (its own order)."""
    ordered = segments[:, dense.dense_order(segments, centre)]
    return (
        kernels.wall_table(segments, fan.range_min, fan.range_max),
        dense.dense_table(ordered, fan.range_min, fan.range_max),
    )


@pytest.mark.parametrize("fan_name", FANS)
def test_the_dense_cast_equals_the_cast_of_every_wall(fan_name: str) -> None:
    fan = FANS[fan_name]
    rng = np.random.default_rng(41)
    hits = answered = 0
    for _ in range(5):
        lean, culled = _tables(_clutter(rng, 600, partial=rng.random() < 0.5), fan, tuple(rng.uniform(-3, 3, 2)))
        for _ in range(40):
            origin = np.array([*rng.uniform(-9, 9, 2), 1.0 + rng.uniform(-0.2, 0.2)])
            rotation = _rotation(rng.uniform(-math.pi, math.pi), rng.choice([0.0, 1e-4, 0.05]), rng.uniform(0, 6.3))
            every, dropped = np.full(fan.count, np.inf), np.full(fan.count, np.inf)
            args = (
                np.zeros(0),
                origin,
                rotation,
                MAX_TILT_COS,
                fan.angle_min,
                fan.inverse_step,
                fan.count,
                fan.turn,
                fan.range_min,
                fan.range_max,
                fan.directions,
            )
            answer = cast_level(lean, *args, every)
            assert cast_level(culled, *args, dropped) == answer
            assert np.array_equal(_bits(dropped), _bits(every))
            answered += answer
            hits += int(np.isfinite(every).sum())
    assert answered > 50 and hits > 0.3 * answered * fan.count  # dense: most beams of most scans hit something


def test_the_dense_cast_refuses_a_partly_covering_wall_within_reach() -> None:
    """The dense tables' shortcut past the partial-band scan (ZLO_MAX, ZHI_MIN) still finds a low box among tall
    ones, wherever it is listed."""
    fan = FANS["hokuyo"]
    rng = np.random.default_rng(3)
    segments = _clutter(rng, 300, partial=False)
    low = boxes_footprints(np.array([[2.0, 0.0, 0.1]]), np.eye(3)[None], np.array([[0.2, 0.2, 0.1]])).segments
    for at in (0, segments.shape[1] // 2, segments.shape[1]):
        table = dense.dense_table(np.insert(segments, [at], low, axis=1), fan.range_min, fan.range_max)
        ranges = np.full(fan.count, np.inf)
        assert not cast_level(
            table,
            np.zeros(0),
            np.array([0.0, 0.0, 0.3]),
            _rotation(0.0, 0.2, 0.0),
            MAX_TILT_COS,
            fan.angle_min,
            fan.inverse_step,
            fan.count,
            fan.turn,
            fan.range_min,
            fan.range_max,
            fan.directions,
            ranges,
        )
        assert np.isinf(ranges).all()


def test_fast_angle_is_within_its_margin() -> None:
    """The sectors' cheap arctangent errs by far less than the margin a wall's arc is widened by."""
    angles = np.linspace(-math.pi, math.pi, 200_001)
    for radius in (1e-3, 1.0, 50.0):
        x, y = radius * np.cos(angles), radius * np.sin(angles)
        error = [
            abs(math.remainder(dense._fast_angle(a, b) - math.atan2(b, a), 2 * math.pi))
            for a, b in zip(x[::7].tolist(), y[::7].tolist())
        ]
        assert max(error) < 2e-5 < dense._ARC_MARGIN / 4
