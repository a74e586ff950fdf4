"""Noise tables kept on disk, so that a run does not draw them (nor import numpy.random) every time it starts.

A camera's table is 4.5 M normals (~0.2 s to draw and standardise on a 2-core machine, 18 MB as float32); a
lidar's is 64 k. An entry is the table's bytes after a one-line header naming exactly what they were made from: the
stream name, the sample count, the dtype, numpy's version (its generator's stream is not promised across versions)
and this format. The header is compared whole, so an entry is used only for the very table it holds, bit for bit
what drawing it again would give. Entries live in ~/.cache/racecar-sim/noise/ (or under $XDG_CACHE_HOME);
RACECAR_SIM_NOISE_CACHE=0 turns the cache off, and a cache that cannot be written is simply not kept.
"""

from __future__ import annotations

import json
import os
import zlib
from collections.abc import Callable
from pathlib import Path

import numpy as np

FORMAT = 1  # bump when how a table is drawn from its name and count changes (core/rng.py, NoiseTable)
OFF_VARIABLE = "RACECAR_SIM_NOISE_CACHE"


def cache_dir() -> Path:
    """Where the entries live."""
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "racecar-sim" / "noise"


def enabled() -> bool:
    return os.environ.get(OFF_VARIABLE, "1") != "0"


def table(name: str, count: int, dtype: np.dtype, length: int, draw: Callable[[], np.ndarray]) -> np.ndarray:
    """The table (`length` values) of stream `name` for samples of `count` values: the kept one, or draw() (then
    kept)."""
    if not enabled():
        return draw()
    header = json.dumps([FORMAT, name, count, dtype.str, np.__version__]).encode() + b"\n"
    path = cache_dir() / f"{zlib.crc32(header):08x}-{count}.bin"
    try:
        with path.open("rb") as file:
            if file.readline() == header:
                values = np.fromfile(file, dtype=dtype)
                if values.size == length:  # a whole entry (a cut one, from a full disk, is drawn again)
                    return values
    except (OSError, ValueError):
        pass
    values = draw()
    keep_entry(path, header, np.ascontiguousarray(values).tobytes())
    return values


def keep_entry(path: Path, *parts: bytes) -> None:
    """Write a cache entry of `parts` at `path`, whole or not at all; a cache that cannot be written is not kept."""
    scratch = path.with_suffix(f".{os.getpid()}.tmp")
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        with scratch.open("wb") as file:
            for part in parts:
                file.write(part)
        scratch.replace(path)  # atomic: processes starting together see the whole entry or none
    except OSError:
        scratch.unlink(missing_ok=True)
