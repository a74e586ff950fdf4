"""Throughput of CDR serialization and MCAP recording for the RACECAR's heaviest topics.

Prints, per message type: our ``serialize`` rate, the rosbags ``serialize_cdr`` rate for
the same message (if rosbags is installed) and their ratio, then the
``McapRecorder.write`` rate (serialize + write, zstd chunks) and the compression ratio.
Not part of the test suite; timings on a shared machine are noisy (take the median of 3).
``--fleet N``: instead, what a run of N cars (`racecar-sim run --world empty --cars N --driver constant --speed 1
--no-camera`, built in-process as bench_fleet's cli_row) records in one sim second: per message type, the count and
the milliseconds ``serialize`` takes for them, then the microseconds a message the writer process's McapRecorder
takes (``write_many`` of 256 at a time, as a hand-over; ``write_serialized`` one by one in code without it), zstd
chunks included, and the CPU a sim second of the run loop's main thread without recording and with the CLI's
recording (a writer process), the topics only it takes handed over as CDR bytes or (as before) made as objects.
``PYTHONPATH=OLD/src`` gives the code before.

    python bench/bench_recording.py [--scale 0.2] [--fleet 4]
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


def fleet_second(cars: int, repeats: int = 5) -> None:
    """Print what `cars` cars record in one sim second: serialize's cost per type, and the writer's per message."""
    from bench_fleet import cli_row
    from machine_info import machine_line

    print(machine_line())
    sim = cli_row(cars, "empty")
    messages: list[tuple[str, Any]] = []
    sim.bus.tap(lambda topic, msg: messages.append((topic, msg)))
    sim.run_until(1.0)
    sim.close()
    by_type: dict[str, list[Any]] = {}
    for _, msg in messages:
        by_type.setdefault(type(msg).__name__, []).append(msg)
    rows, total = [], 0.0
    for name, pool in by_type.items():
        times = []
        for _ in range(repeats):
            start = time.perf_counter()
            for msg in pool:
                msgs.serialize(msg)
            times.append(time.perf_counter() - start)
        rows.append((statistics.median(times), name, len(pool)))
        total += rows[-1][0]
    print(f"{cars} cars in empty, one sim second: {len(messages)} messages; serialize, median of {repeats}")
    for seconds, name, count in sorted(rows, reverse=True):
        print(f"  {name:<22} {count:>5}  {seconds * 1e3:6.2f} ms  {seconds / count * 1e6:6.2f} µs each")
    print(f"  {'all':<22} {len(messages):>5}  {total * 1e3:6.2f} ms")
    records = [(topic, msgs.msgtype_of(msg), msgs.serialize(msg), i) for i, (topic, msg) in enumerate(messages)]
    per_message = []
    with tempfile.TemporaryDirectory() as tmp:
        for run in range(repeats):
            with McapRecorder(Path(tmp) / f"{run}.mcap") as rec:
                start = time.perf_counter()
                for second in range(5):  # 5 sim s: chunks close by time, as in a run
                    batch = [(t, m, d, second * 10**9 + i) for t, m, d, i in records]
                    if hasattr(rec, "write_many"):
                        for first in range(0, len(batch), 256):
                            rec.write_many(batch[first : first + 256])
                    else:
                        for topic, msgtype, data, stamp in batch:
                            rec.write_serialized(topic, msgtype, data, stamp)
                per_message.append((time.perf_counter() - start) / (5 * len(records)))
    print(f"writer: {statistics.median(per_message) * 1e6:.2f} µs a message (McapRecorder, zstd), median of {repeats}")
    runs: dict[str, list[float]] = {"bytes": [], "objects": [], "off": []}
    for _ in range(3):  # interleaved: the machine's load moves all alike
        for way in runs:
            runs[way].append(_loop_cpu(cars, way))
    cpu = {way: statistics.median(seconds) * 1e3 for way, seconds in runs.items()}
    print(
        f"main thread, CPU a sim second (run loop after 1 s, {LOOP_SECONDS:g} sim s, median of 3): {cpu['off']:.1f} ms "
        f"without recording; recording (RunRecording, a writer process) {cpu['bytes']:.1f} ms "
        f"(the recording's {cpu['bytes'] - cpu['off']:.1f} ms), {cpu['objects']:.1f} ms with every message made as an "
        f"object ({cpu['objects'] - cpu['off']:.1f} ms)"
    )


LOOP_SECONDS = 5.0


def _loop_cpu(cars: int, way: str) -> float:
    """CPU seconds of the main thread a sim second in `cars` cars' run loop (cli_row): with the CLI's recording
    ("bytes": what a recorder alone takes is handed over as CDR bytes; "objects": every message made as an object, as
    before Bus.cdr_only) or without it ("off"). Thread time, which other processes on the machine leave alone better
    than wall time."""
    from bench_fleet import cli_row
    from racecar_sim.bus import Bus
    from racecar_sim.recording.run_recording import RunRecording

    sim = cli_row(cars, "empty")
    cdr_only = getattr(Bus, "cdr_only", None)
    if way == "objects" and cdr_only is not None:
        Bus.cdr_only = lambda self, topic: False  # type: ignore[method-assign]
    try:
        with tempfile.TemporaryDirectory() as tmp:
            recording = RunRecording(sim.bus, lambda: sim.time_ns, Path(tmp) / "run.mcap") if way != "off" else None
            sim.run_until(1.0)
            start = time.thread_time()
            sim.run_until(1.0 + LOOP_SECONDS)
            seconds = time.thread_time() - start
            if recording is not None:
                recording.close()
            sim.close()
    finally:
        if cdr_only is not None:
            Bus.cdr_only = cdr_only  # type: ignore[method-assign]
    return seconds / LOOP_SECONDS


def main() -> None:
    """Run the benchmark and print one line per message type."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--scale", type=float, default=1.0, help="multiply message counts")
    parser.add_argument("--compression", default="zstd", choices=["zstd", "lz4", "none"])
    parser.add_argument("--fleet", type=int, metavar="N", help="a run of N cars' messages instead (see above)")
    args = parser.parse_args()
    if args.fleet:
        fleet_second(args.fleet)
        return
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
