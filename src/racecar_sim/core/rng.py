"""One seeded random generator per run, split into independent streams per consumer."""

from __future__ import annotations

import zlib

import numpy as np

from racecar_sim.core.errors import ConfigError


def check_seed(seed: object) -> int:
    """A run's seed: a whole number >= 0 (numpy's seed sequences take no negative or fractional seeds)."""
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise ConfigError(f"seed must be a whole number >= 0, got {seed!r}")
    return int(seed)


def stream(seed: int, name: str) -> np.random.Generator:
    """An independent generator for the consumer called `name` (a sensor, a driver) in run `seed`.

    Streams are keyed by name, not by creation order, so adding a sensor never changes the
    noise another sensor sees.
    """
    return np.random.default_rng([seed, zlib.crc32(name.encode())])


def sample_stream(seed: int, name: str, stamp_ns: int) -> np.random.Generator:
    """A generator for one sample (a scan, an image) of `name` taken at sim time `stamp_ns`.

    Keyed by the stamp, so a sample's noise is the same whether or not earlier samples were taken
    (a sensor that skips work while nobody listens still reproduces the same data).
    """
    return np.random.default_rng([seed, zlib.crc32(name.encode()), stamp_ns])
