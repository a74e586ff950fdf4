"""core.rng.NoiseTable: the sensors' per-(seed, stamp) noise, checked against what it promises - unit normal values,
independent within a sample, the same for the same (seed, stamp) whatever came before, different otherwise."""

from __future__ import annotations

import numpy as np
from scipy import stats

from racecar_sim.core.rng import NoiseTable


def test_a_sample_is_a_function_of_seed_and_stamp():
    table = NoiseTable("test/scan", 1081)
    first = table.sample(3, 25_000_000)
    for stamp in range(0, 10**9, 10**8):  # other samples in between change nothing
        table.sample(3, stamp)
    np.testing.assert_array_equal(table.sample(3, 25_000_000), first)
    np.testing.assert_array_equal(NoiseTable("test/scan", 1081).sample(3, 25_000_000), first)  # a fresh table too
    assert not np.array_equal(table.sample(4, 25_000_000), first)  # another seed
    assert not np.array_equal(table.sample(3, 50_000_000), first)  # another stamp
    assert not np.array_equal(NoiseTable("test/other", 1081).sample(3, 25_000_000), first)  # another stream


def test_batched_samples_are_the_single_samples_bit_for_bit():
    table = NoiseTable("car1/scan", 64)
    seeds = np.array([0, 1, 100, 2**31 - 1, 2**32 - 1, 2**32, 2**40, 7])
    stamps = np.array([0, 50_000_000, 2**32 - 1, 2**32, 1, 2**62, 123_456_789_000, 0])
    rows = table.samples(seeds, stamps)
    for i, (seed, stamp) in enumerate(zip(seeds.tolist(), stamps.tolist())):
        np.testing.assert_array_equal(rows[i], table.sample(seed, stamp))


def test_values_are_independent_unit_normals():
    """Over 400 samples of 1081 values: normal by a Kolmogorov-Smirnov test, mean 0 and variance 1 within their
    sampling error, and neighbouring values within a sample uncorrelated (the two windows never overlap)."""
    table = NoiseTable("test/stats", 1081)
    values = np.stack([table.sample(11, k * 25_000_000) for k in range(400)])
    flat = values.ravel()
    n = flat.size
    assert abs(flat.mean()) < 4.0 / np.sqrt(n)
    assert abs(flat.var() - 1.0) < 4.0 * np.sqrt(2.0 / n)
    assert stats.kstest(flat, "norm").pvalue > 1e-3
    lag1 = np.mean(values[:, 1:] * values[:, :-1])
    assert abs(lag1) < 4.0 / np.sqrt(values[:, 1:].size)
    first, second = table.offsets(11, 0)
    gap = (second - first) % table.size
    assert table.count <= gap <= table.size - table.count  # the windows do not overlap


def test_float32_tables_for_images():
    table = NoiseTable("test/image", 640 * 480, np.float32)
    frame = table.sample(0, 0)
    assert frame.dtype == np.float32 and frame.shape == (640 * 480,)
    assert abs(float(frame.std()) - 1.0) < 0.01


def test_a_kept_table_is_the_drawn_one_bit_for_bit(tmp_path, monkeypatch):
    """The disk cache (core/noise_cache.py) gives exactly the table a fresh draw gives: first drawn and kept, then
    read back; a cut entry is drawn again, and RACECAR_SIM_NOISE_CACHE=0 neither reads nor writes."""
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    monkeypatch.setenv("RACECAR_SIM_NOISE_CACHE", "0")
    drawn = NoiseTable("test/kept", 1081).values
    assert not (tmp_path / "racecar-sim").exists()
    monkeypatch.delenv("RACECAR_SIM_NOISE_CACHE")
    first = NoiseTable("test/kept", 1081).values
    (entry,) = (tmp_path / "racecar-sim" / "noise").iterdir()
    kept = NoiseTable("test/kept", 1081).values
    assert drawn.dtype == first.dtype == kept.dtype == np.float64
    assert drawn.tobytes() == first.tobytes() == kept.tobytes()
    entry.write_bytes(entry.read_bytes()[:-8])  # a cut entry (a full disk)
    assert NoiseTable("test/kept", 1081).values.tobytes() == drawn.tobytes()
    assert NoiseTable("test/kept", 1082).values.size == NoiseTable("test/kept", 1082).size + 1082  # its own entry
    float32 = NoiseTable("test/kept", 1081, np.float32).values
    assert float32.dtype == np.float32 and len(list(entry.parent.iterdir())) == 3
