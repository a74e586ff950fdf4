"""The wall-follow driver's closed-form wall fit against the least-squares (SVD) line it replaced, on random scans."""

from __future__ import annotations

import math

import numpy as np
import pytest

from racecar_sim.bus import Bus
from racecar_sim.drivers import WallFollower, wall_follow_config
from racecar_sim.drivers.constant import NAVIGATION
from racecar_sim.msgs import AckermannDriveStamped, Header, LaserScan

BEAMS, ANGLE_MIN, INCREMENT, RANGE_MAX = 1081, -2.3561944902, 0.0043633231, 10.0


def svd_wall(
    ranges: np.ndarray, angles: np.ndarray, side: float, sector: tuple[float, float], patch: float, range_max: float
) -> tuple[float, float, float]:
    """The wall as the driver first found it: the principal direction of the patch by SVD. Also returns how well
    that direction is defined: the gap of the two singular values squared, relative to the larger."""
    bearing = side * angles
    inside = (bearing >= math.radians(sector[0])) & (bearing <= math.radians(sector[1]))
    points = np.stack([ranges[inside] * np.cos(angles[inside]), ranges[inside] * np.sin(angles[inside])], axis=1)
    points = points[ranges[inside] < range_max]
    if len(points) < 2:
        return 0.0, range_max, 1.0
    nearest = points[np.argmin(np.einsum("ij,ij->i", points, points))]
    near = points[np.hypot(*(points - nearest).T) <= patch]
    if len(near) < 2:
        return 0.0, float(np.hypot(*nearest)), 1.0
    centre = near.mean(axis=0)
    _, singular, vt = np.linalg.svd(near - centre, full_matrices=False)
    along = vt[0] if vt[0][0] >= 0 else -vt[0]
    gap = (singular[0] ** 2 - singular[1] ** 2) / max(singular[0] ** 2, 1e-300)
    return -side * math.atan2(along[1], along[0]), abs(float(centre[0] * along[1] - centre[1] * along[0])), gap


def random_scan(rng: np.random.Generator) -> np.ndarray:
    """Ranges (float64) of a few random walls and posts around the laser, with noise, dropouts and clipped beams."""
    angles = ANGLE_MIN + INCREMENT * np.arange(BEAMS)
    ranges = np.full(BEAMS, np.inf)
    directions = np.stack([np.cos(angles), np.sin(angles)], axis=1)
    for _ in range(rng.integers(1, 5)):  # walls: lines at distance d with normal direction phi
        d, phi = rng.uniform(0.2, 6.0), rng.uniform(-math.pi, math.pi)
        cos = directions @ np.array([math.cos(phi), math.sin(phi)])
        hit = np.where(cos > 1e-3, d / np.maximum(cos, 1e-3), np.inf)
        ranges = np.minimum(ranges, hit)
    for _ in range(rng.integers(0, 4)):  # posts: small discs
        centre, radius = rng.uniform(-4, 4, 2), rng.uniform(0.05, 0.5)
        along = directions @ centre
        closest = np.sum(centre**2) - along**2
        through = radius**2 - closest
        hit = np.where((through >= 0) & (along > 0), along - np.sqrt(np.maximum(through, 0)), np.inf)
        ranges = np.minimum(ranges, np.where(hit > 0, hit, np.inf))
    ranges = ranges + rng.normal(0, rng.choice([0.0, 0.01, 0.05]), BEAMS)
    ranges = np.where(rng.random(BEAMS) < rng.choice([0.0, 0.05, 0.5]), np.inf, ranges)  # dropouts
    ranges = np.where(np.isfinite(ranges), np.clip(ranges, 0.1, RANGE_MAX), np.inf)  # as the lidar clips
    return ranges.astype(np.float32).astype(np.float64)


@pytest.mark.parametrize("side", ["left", "right"])
def test_closed_form_fit_matches_the_svd_fit_on_random_scans(side):
    rng = np.random.default_rng(14)
    config = wall_follow_config(side=side)
    follower = WallFollower(Bus(), config)
    angles = ANGLE_MIN + INCREMENT * np.arange(BEAMS)
    checked = 0
    for _ in range(400):
        ranges = random_scan(rng)
        approach, distance = follower._wall(np.nan_to_num(ranges, posinf=RANGE_MAX), angles)
        want_approach, want_distance, gap = svd_wall(
            np.nan_to_num(ranges, posinf=RANGE_MAX), angles, follower.side, config.sector, config.patch, RANGE_MAX
        )
        if gap < 1e-6:  # a round patch: no direction is the line's, in either formulation
            continue
        checked += 1
        turn = (approach - want_approach + math.pi / 2) % math.pi - math.pi / 2  # a line's direction is mod pi
        assert abs(turn) < 1e-9 / gap and distance == pytest.approx(want_distance, abs=1e-9 / gap)
        assert abs(approach - want_approach) < 1e-9 / gap or abs(abs(approach) - math.pi / 2) < 1e-6
    assert checked > 350


def scan_of(ranges: np.ndarray, stamp_ns: int) -> LaserScan:
    return LaserScan(
        Header.at(stamp_ns, "laser"),
        ANGLE_MIN,
        ANGLE_MIN + INCREMENT * (BEAMS - 1),
        INCREMENT,
        0.0,
        0.025,
        0.1,
        RANGE_MAX,
        ranges.astype(np.float32),
        np.zeros(BEAMS, np.float32),
    )


def commands_for(scans: list[np.ndarray]) -> list[tuple[float, float]]:
    bus = Bus()
    commands: list[AckermannDriveStamped] = []
    bus.subscribe(NAVIGATION, commands.append)
    WallFollower(bus)
    for k, ranges in enumerate(scans):
        bus.publish("/scan", scan_of(ranges, k * 25_000_000))
    return [(c.drive.steering_angle, c.drive.speed) for c in commands]


def test_nan_and_infinite_beams_read_as_before():
    """NaN reads as 0 m and +-inf as range_max (numpy's nan_to_num), wherever they are in the scan: the driver's
    fast path for clean scans must decide as the scan with those values written in."""
    rng = np.random.default_rng(3)
    raw, clean = [], []
    for _ in range(60):
        ranges = random_scan(rng)
        ranges[rng.random(BEAMS) < 0.01] = rng.choice([np.nan, -np.inf, np.inf, RANGE_MAX])
        raw.append(ranges)
        clean.append(np.nan_to_num(ranges, nan=0.0, posinf=RANGE_MAX, neginf=RANGE_MAX))
    assert commands_for(raw) == commands_for(clean)


@pytest.mark.parametrize("side", ["left", "right"])
@pytest.mark.parametrize("range_max", [RANGE_MAX, 5.6])
def test_the_compiled_readings_equal_numpys_on_random_scans(side, range_max):
    """The readings of a lidar's scan in one compiled call (wall_fit.read_scan: the wall fit, the free distance ahead)
    are the numpy path's to the bit: on random float32 scans, beams at range_max (5.6 m is above its float32, which
    numpy's float32 comparison does not count as an echo), +inf beams and nearly empty sectors; a scan with a NaN or
    -inf is left to the numpy path."""
    import racecar_sim.drivers.wall_fit  # noqa: F401  (numba loaded: the driver takes the compiled path)

    rng = np.random.default_rng(21)
    follower = WallFollower(Bus(), wall_follow_config(side=side))
    follower._range_max = range_max
    angles = ANGLE_MIN + INCREMENT * np.arange(BEAMS)
    sector, _, _ = follower._beams(angles)
    compiled = 0
    for k in range(300):
        ranges = np.minimum(random_scan(rng), range_max).astype(np.float32)
        if k % 3 == 0:  # beams clamped to range_max, as the lidar clamps them
            ranges[rng.random(BEAMS) < 0.3] = np.float32(range_max)
        if k % 5 == 0:  # a side sector with one echo, the rest at range_max or without echo
            ranges[sector] = rng.choice([np.float32(range_max), np.inf], ranges[sector].shape)
            ranges[sector.start + rng.integers(0, sector.stop - sector.start)] = 1.0
        want = follower._readings(ranges, angles)
        got = follower._read(ranges, angles)
        assert got is not None
        compiled += 1
        assert got == want, k
    assert compiled == 300
    ranges = random_scan(rng).astype(np.float32)
    for bad in (np.nan, -np.inf):
        ranges[7] = bad
        assert follower._read(ranges, angles) is None
