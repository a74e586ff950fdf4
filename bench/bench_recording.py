"""Throughput of CDR serialization and MCAP recording for the RACECAR's heaviest topics.

Prints, per message type: our ``serialize`` rate, the rosbags ``serialize_cdr`` rate for
the same message (if rosbags is installed) and their ratio, then the
``McapRecorder.write`` rate (serialize + write, zstd chunks) and the compression ratio.
Not part of the test suite; timings on a shared machine are noisy (take the median of 3).

    python bench/bench_recording.py [--scale 0.2]
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from collections.abc import Callable
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np

from racecar_sim import msgs
from racecar_sim.recording import McapRecorder


def _scan(rng: np.random.Generator) -> msgs.LaserScan:
    ranges = (3.0 + np.sin(np.linspace(0, 12, 1081)) + rng.normal(0, 0.01, 1081)).astype(np.float32)
    return msgs.LaserScan(msgs.Header.at(0, "laser"), -2.356, 2.356, 0.00436, 0.0, 0.025, 0.1, 10.0,
                          ranges)  # fmt: skip


def _image(rng: np.random.Generator) -> msgs.Image:
    gradient = np.add.outer(np.arange(480), np.arange(640)) % 256
    pixels = np.repeat(gradient[:, :, None], 3, axis=2) + rng.integers(0, 3, (480, 640, 3))
    data = pixels.astype(np.uint8).tobytes()
    return msgs.Image(msgs.Header.at(0, "camera"), 480, 640, "bgr8", 0, 1920, data)


def _odometry(rng: np.random.Generator) -> msgs.Odometry:
    odom = msgs.Odometry(msgs.Header.at(int(rng.integers(10**9)), "odom"), "base_link")
    odom.pose.pose.position = msgs.Point(*rng.normal(size=3))
    odom.twist.twist.linear = msgs.Vector3(*rng.normal(size=3))
    return odom


def _rate(count: int, func: Callable[[], Any], repeats: int = 3) -> float:
    """Median calls per second over ``repeats`` runs of ``count`` calls."""
    rates = []
    for _ in range(repeats):
        start = time.perf_counter()
        for _ in range(count):
            func()
        rates.append(count / (time.perf_counter() - start))
    return statistics.median(rates)


def _record_rate(topic: str, pool: list[Any], count: int, workdir: Path, compression: str) -> tuple[float, float]:
    """Median write rate (msg/s) and payload/file size ratio over 3 recordings."""
    rates, ratio = [], 0.0
    payload = sum(len(msgs.serialize(m)) for m in pool) / len(pool)
    for run in range(3):
        path = workdir / f"{topic.strip('/')}_{run}.mcap"
        start = time.perf_counter()
        with McapRecorder(path, compression=compression) as rec:
            for i in range(count):
                rec.write(topic, pool[i % len(pool)], i)
        rates.append(count / (time.perf_counter() - start))
        ratio = count * payload / path.stat().st_size
    return statistics.median(rates), ratio


def main() -> None:
    """Run the benchmark and print one line per message type."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--scale", type=float, default=1.0, help="multiply message counts")
    parser.add_argument("--compression", default="zstd", choices=["zstd", "lz4", "none"])
    args = parser.parse_args()
    try:
        from rosbags.typesys import Stores, get_typestore

        store: Any = get_typestore(Stores.ROS2_HUMBLE)
    except ImportError:
        store = None
    rng = np.random.default_rng(0)
    # Pools of distinct noisy messages, so that compression sees a realistic stream.
    cases = [("/scan", [_scan(rng) for _ in range(64)], 5000),
             ("/image", [_image(rng) for _ in range(4)], 300),
             ("/odom", [_odometry(rng) for _ in range(64)], 5000)]  # fmt: skip
    print(f"record: {args.compression} chunks; ratio = ours/rosbags, then payload/file size")
    print(f"{'message':<10} {'bytes':>7} {'serialize/s':>12} {'rosbags/s':>10} {'ratio':>6}"
          f" {'record/s':>9} {'MB/s':>7} {'ratio':>6}")  # fmt: skip
    with tempfile.TemporaryDirectory() as tmp:
        for topic, pool, count in cases:
            msg = pool[0]
            count = max(10, int(count * args.scale))
            size = len(msgs.serialize(msg))
            ours = _rate(count, partial(msgs.serialize, msg))
            theirs = float("nan")
            if store is not None:
                msgtype = msgs.msgtype_of(msg)
                ref = store.deserialize_cdr(msgs.serialize(msg), msgtype)
                theirs = _rate(count, partial(store.serialize_cdr, ref, msgtype))
            recorded, ratio = _record_rate(topic, pool, count, Path(tmp), args.compression)
            name = type(msg).__name__
            print(f"{name:<10} {size:>7} {ours:>12,.0f} {theirs:>10,.0f} {ours / theirs:>6.2f}"
                  f" {recorded:>9,.0f} {recorded * size / 1e6:>7.0f} {ratio:>6.2f}")  # fmt: skip


if __name__ == "__main__":
    main()
