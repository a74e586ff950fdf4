"""A run's seed, and the sensors' noise: per stream name and (seed, stamp), the same however many samples came
before (a sensor that skips work while nobody listens still reproduces the same data)."""

from __future__ import annotations

import zlib
from typing import ClassVar, overload

import numpy as np
import numpy.typing as npt

from racecar_sim.core import noise_cache
from racecar_sim.core.errors import ConfigError


def check_seed(seed: object) -> int:
    """A run's seed: a whole number >= 0 (numpy's seed sequences take no negative or fractional seeds)."""
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise ConfigError(f"seed must be a whole number >= 0, got {seed!r}")
    return int(seed)


_MASK64 = (1 << 64) - 1

# uint64 arrays of seeds, stamps and hashes (numpy's stubs widen uint64 mixed with a Python int to some integer)
_Ints = npt.NDArray[np.integer]


@overload
def _splitmix(x: int) -> int: ...
@overload
def _splitmix(x: _Ints) -> _Ints: ...
def _splitmix(x: int | _Ints) -> int | _Ints:
    """splitmix64's finaliser: a Python int (< 2**64) or a uint64 array, mixed into a well-spread 64-bit value."""
    x = (x + 0x9E3779B97F4A7C15) & _MASK64
    x = ((x ^ (x >> 30)) * 0xBF58476D1CE4E5B9) & _MASK64
    x = ((x ^ (x >> 27)) * 0x94D049BB133111EB) & _MASK64
    return x ^ (x >> 31)


class NoiseTable:
    """Standard normal noise for the samples of one stream (a sensor's scans or images), keyed by (seed, stamp).

    Drawing a fresh generator and `count` normals per sample costs more than the sensor itself (a camera frame:
    307k draws, ~4 ms). Here the normals are drawn once per stream name (the same table in every run) and a
    sample's noise is the mean of two non-overlapping windows of the table, scaled back to unit variance, at
    offsets hashed from (seed, stream, stamp): still exactly N(0, 1) per value and independent across a sample's
    values, the same for a given (seed, stamp) however many samples were taken before, different for another
    seed. The table is standardised (mean exactly 0, variance 1), so averages over many samples are unbiased.
    Windows of different samples may share values (two random samples overlap with probability ~2 count / size per
    window pair), which no per-sample statistic sees.
    """

    _shared: ClassVar[dict[tuple[str, int, str], NoiseTable]] = {}

    def __init__(self, name: str, count: int, dtype: type = np.float64) -> None:
        self.name, self.count = name, count
        self.size = max(1 << 16, 1 << (8 * count - 1).bit_length())  # a power of two, >= 8 windows
        self.values: npt.NDArray[np.floating] = noise_cache.table(
            name, count, np.dtype(dtype), self.size + count, lambda: self._draw(dtype)
        )  # kept on disk: the same table in every run
        self._key = zlib.crc32(name.encode()) << 32

    def _draw(self, dtype: type) -> npt.NDArray[np.floating]:
        values = np.random.default_rng([zlib.crc32(self.name.encode()), 0x7AB1E]).standard_normal(self.size)
        # exactly mean 0, variance 1 over the table: every sample reuses its values, so the table's own sampling
        # error would otherwise be a bias shared by all samples, forever
        values = ((values - values.mean()) / values.std()).astype(dtype)
        table: npt.NDArray[np.floating] = np.concatenate([values, values[: self.count]])  # any window is one slice
        table *= np.sqrt(0.5).astype(dtype)  # so that the sum of two windows has unit variance
        return table

    @classmethod
    def shared(cls, name: str, count: int, dtype: type = np.float64) -> NoiseTable:
        """The process-wide table of a stream (drawn on first use; tables are read-only once drawn)."""
        key = (name, count, np.dtype(dtype).str)
        table = cls._shared.get(key)
        if table is None:
            table = cls._shared[key] = cls(name, count, dtype)
        return table

    @overload
    def offsets(self, seed: int, stamp_ns: int) -> tuple[int, int]: ...
    @overload
    def offsets(self, seed: _Ints, stamp_ns: _Ints) -> tuple[_Ints, _Ints]: ...
    def offsets(self, seed: int | _Ints, stamp_ns: int | _Ints) -> tuple[int | _Ints, int | _Ints]:
        """The two window starts of the samples stamped `stamp_ns` in run `seed`: ints, or uint64 arrays for
        arrays of seeds and stamps (the same values element by element)."""
        h = _splitmix(_splitmix((seed * 0x100000001B3 + self._key) & _MASK64) ^ stamp_ns)
        first = h & (self.size - 1)
        # the second window starts past the end of the first, and ends before the first starts again
        second = (first + self.count + (h >> 32) % (self.size - 2 * self.count + 1)) & (self.size - 1)
        return first, second

    def sample(self, seed: int, stamp_ns: int) -> np.ndarray:
        """The unit normal noise (count,) of the sample stamped `stamp_ns` in run `seed` (a new array)."""
        first, second = self.offsets(seed, stamp_ns)
        n, v = self.count, self.values
        return v[first : first + n] + v[second : second + n]

    def samples(self, seeds: np.ndarray, stamps_ns: np.ndarray) -> np.ndarray:
        """sample() for arrays of seeds and stamps: (len, count), row i that of (seeds[i], stamps_ns[i])."""
        first, second = self.offsets(np.asarray(seeds).astype(np.uint64), np.asarray(stamps_ns).astype(np.uint64))
        window = np.arange(self.count)
        v = self.values
        noise: npt.NDArray[np.floating] = (
            v[first.astype(np.intp)[:, None] + window] + v[second.astype(np.intp)[:, None] + window]
        )
        return noise
