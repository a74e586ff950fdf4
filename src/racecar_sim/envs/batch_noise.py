"""The lidar noise generators of many worlds at once: sample_stream(seed, name, stamp) for a batch of (seed, stamp).

sample_stream builds numpy's default generator from the entropy [seed, crc32(name), stamp]: a SeedSequence hashes
it into a pool, the pool gives PCG64 its 128-bit state and increment. Building one costs ~14 µs, as much as the scan's
1081 normal draws; here the SeedSequence hashing (numpy's documented, frozen algorithm) runs as uint32 array code
over the batch, and each world's PCG64 state is set on one reused generator, so the draws are numpy's own and the
values those of sample_stream, bit for bit (tests/test_envs_batch.py checks it).
"""

from __future__ import annotations

import threading
import zlib

import numpy as np

_INIT_A, _MULT_A, _INIT_B, _MULT_B = 0x43B0D7E5, 0x931E8875, 0x8B51F9DD, 0x58F38DED
_MIX_L, _MIX_R, _SHIFT, _POOL = 0xCA01F9DD, 0x4973F715, 16, 4
_PCG_MULT = (2549297995355413924 << 64) + 4865540595714422341
_M128 = (1 << 128) - 1
_U32 = np.uint32


def _words(values: np.ndarray) -> list[np.ndarray]:
    """SeedSequence's uint32 words of non-negative ints < 2**64 that all need the same number of words."""
    values = values.astype(np.uint64)
    low = (values & np.uint64(0xFFFFFFFF)).astype(_U32)
    if (values >> np.uint64(32)).any():
        return [low, (values >> np.uint64(32)).astype(_U32)]
    return [low]


def _pool(entropy: list[np.ndarray]) -> list[np.ndarray]:
    """SeedSequence.mix_entropy over a batch: `entropy` words (each (n,), at most the pool size of them)."""
    const = [_INIT_A]

    def hashmix(value: np.ndarray) -> np.ndarray:
        value = value ^ _U32(const[0])
        const[0] = (const[0] * _MULT_A) & 0xFFFFFFFF
        value = value * _U32(const[0])
        return value ^ (value >> _U32(_SHIFT))

    zero = np.zeros_like(entropy[0])
    pool = [hashmix(entropy[i] if i < len(entropy) else zero) for i in range(_POOL)]
    for src in range(_POOL):
        for dst in range(_POOL):
            if src != dst:
                mixed = _U32(_MIX_L) * pool[dst] - _U32(_MIX_R) * hashmix(pool[src])
                pool[dst] = mixed ^ (mixed >> _U32(_SHIFT))
    for src in range(_POOL, len(entropy)):
        for dst in range(_POOL):
            mixed = _U32(_MIX_L) * pool[dst] - _U32(_MIX_R) * hashmix(entropy[src])
            pool[dst] = mixed ^ (mixed >> _U32(_SHIFT))
    return pool


def _pcg64_states(seeds: np.ndarray, crc: int, stamps: np.ndarray) -> list[tuple[int, int]]:
    """(state, increment) of PCG64(SeedSequence([seed, crc, stamp])) per world (seeds, stamps of one word count)."""
    with np.errstate(over="ignore"):
        pool = _pool(_words(seeds) + [np.full(len(seeds), crc, _U32)] + _words(stamps))
        const, words = _INIT_B, []
        for i in range(8):  # generate_state(4, uint64): 8 uint32 words, little-endian pairs
            value = pool[i % _POOL] ^ _U32(const)
            const = (const * _MULT_B) & 0xFFFFFFFF
            value = value * _U32(const)
            words.append(value ^ (value >> _U32(_SHIFT)))
    w = [x.astype(np.uint64) for x in words]
    parts = [(w[2 * k] | (w[2 * k + 1] << np.uint64(32))).tolist() for k in range(4)]
    states = []
    for seed_hi, seed_lo, inc_hi, inc_lo in zip(*parts):
        inc = ((((inc_hi << 64) | inc_lo) << 1) | 1) & _M128
        state = inc  # srandom: state 0, one step, add the seed, one step
        state = ((state + ((seed_hi << 64) | seed_lo)) * _PCG_MULT + inc) & _M128
        states.append((state, inc))
    return states


class ScanNoise:
    """Gaussian range noise of one lidar's scans, stamped per world, exactly as LidarPublisher draws it."""

    def __init__(self, stream: str, mean: float, stddev: float, count: int) -> None:
        self.crc, self.mean, self.stddev, self.count = zlib.crc32(stream.encode()), mean, stddev, count
        self._local = threading.local()  # one reused generator per thread

    def states(self, seeds: np.ndarray, stamps_ns: np.ndarray) -> list[tuple[int, int]]:
        """Each world's generator state (PCG64 state, increment) for its scan stamped `stamps_ns` (one call for the
        whole batch: the hashing's cost is per call, not per world)."""
        seeds, stamps = np.asarray(seeds, np.int64), np.asarray(stamps_ns, np.int64)
        if (seeds < 0).any() or (stamps < 0).any():
            raise ValueError("ScanNoise: seeds and stamps must be non-negative")
        out: list[tuple[int, int]] = [(0, 0)] * len(seeds)
        # worlds whose ints need the same number of uint32 words hash together (zero is one word)
        wide = (seeds >= 2**32).astype(int) * 2 + (stamps >= 2**32)
        for kind in np.unique(wide).tolist():
            worlds = np.flatnonzero(wide == kind)
            for i, state in zip(worlds.tolist(), _pcg64_states(seeds[worlds], self.crc, stamps[worlds])):
                out[i] = state
        return out

    def add(self, ranges: np.ndarray, states: list[tuple[int, int]]) -> None:
        """Add each world's noise, drawn from its generator state (states()), to its row of `ranges` (N, count)."""
        local = self._local
        if not hasattr(local, "bits"):
            local.bits = np.random.PCG64(0)
            local.generator = np.random.Generator(local.bits)
        for i, (state, inc) in enumerate(states):
            local.bits.state = {"bit_generator": "PCG64", "state": {"state": state, "inc": inc},
                                "has_uint32": 0, "uinteger": 0}
            ranges[i] += local.generator.normal(self.mean, self.stddev, self.count)
